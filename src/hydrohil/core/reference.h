/* reference.h: the continuous reference model (SPEC §6): the same physics as the hybrid model without
 * discrete modes. Continuous LuGre friction (SPEC §5), end stops as unilateral spring-dampers
 * (F = max(0, k*d + c*dd/dt) on penetration d: it pushes, never pulls; HH_STOP_K, HH_STOP_C), orifices
 * with a narrow laminar region (HH_DP_LAM_REF) so the Jacobian stays finite, the spool's ends a stiff
 * spring-damper too. Stiff: solved by LSODA/Radau in Python (simulation/reference.py, calling
 * hh_reference_rhs), or by an explicit fixed step for the largest-stable-step comparison (maxstep). */
#ifndef HH_REFERENCE_H
#define HH_REFERENCE_H
#include "cylinder.h"
#include "friction.h"
#include "rk.h"

HH_INLINE double end_stop_force(double xp, double vp, const double *p);
HH_INLINE void reference_rhs(const double *y, double ud, const int64_t *m, const double *p, const double *sc,
                          double *dy);
static void continuous_step(int method, double *y, const double *p, double ud, double h);

#endif
