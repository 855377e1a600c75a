/* valve.h: servo-solenoid 4-way valve (SPEC §3): spool dynamics with limits (eq 1-2, §3.1) and the
 * pseudo-section static model (eq 3, §3.2). Pseudo-sections are in the paper's units, (l/min)/sqrt(bar);
 * flows are converted to SI at the orifice. */
#ifndef HH_VALVE_H
#define HH_VALVE_H
#include "core.h"
#include "hc_sqrt_law.h"
#include "hc_servo_valve.h"

typedef struct { double as1, as2, a1t, a2t; } hh_sections;

HH_INLINE double section(double x, const double *k);
HH_INLINE hh_sections pseudo_sections(double x, const double *p);
HH_INLINE hh_sections pseudo_section_slopes(double x, const double *p);
HH_INLINE double orifice_flow(double area, double dp, double dp_t);
HH_INLINE double orifice_slope(double area, double dp, double dp_t);
HH_INLINE int spool_limits(double xs, double vs, double ud, const double *p, double *dxs, double *dvs);
HH_INLINE int spool_derivatives(double xs, double vs, double ud, const double *p, double *dxs, double *dvs);
HH_INLINE void spool_end_block(double xs, double vs, double *dxs, double *dvs);
HH_INLINE int spool_rhs(double xs, double vs, double ud, const double *p, double *dxs, double *dvs);
HH_INLINE void spool_project(double *xs, double *vs, double lv);
HH_INLINE double spool_stop_acceleration(double xs, double vs, const double *p);

#endif
