/* cylinder.h: differential cylinder (SPEC §4): chamber volumes, effective bulk modulus (eq 21),
 * internal leakage (eq 22), continuity with the valve flows (SPEC §3.2), piston forces (eq 28). */
#ifndef HH_CYLINDER_H
#define HH_CYLINDER_H
#include "valve.h"
#include "hc_lugre_cylinder.h"

HH_INLINE double bulk_modulus(double pressure, int chamber, const double *p);
HH_INLINE void volumes(double xp, const double *p, double *v1, double *v2);
HH_INLINE void valve_flows(double xs, double p1, double p2, const double *p, double dp_t, double *q1, double *q2);
HH_INLINE void chamber_pressure_rates(double xs, double p1, double p2, double xp, double vp, const double *p,
                                   double dp_t, double c1, double c2, double *dp1, double *dp2);
HH_INLINE void quasi_static_drift(double xs, double dxs, double p1, double p2, double dvp, const double *p,
                               double dp_t, double *d1, double *d2);
HH_INLINE double external_force(double p1, double p2, const double *p);

#endif
