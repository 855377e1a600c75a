/* delay.h: pure input delay of the valve (SPEC §3.1) as a ring of zero-order-held commands.
 * The command u_k holds over [t_k, t_k + h). Delayed by (n + alpha)*h, the spool input over step k is
 * u_{k-n-1} for a fraction alpha of the step and u_{k-n} for the rest; the fixed-step model uses their
 * step average (1 - alpha)*u_{k-n} + alpha*u_{k-n-1}: a fractional delay is interpolated, not rounded. */
#ifndef HH_DELAY_H
#define HH_DELAY_H
#include "core.h"

static double delay_push(hh_delay *d, double u, double *u_new, double *u_old);

#endif
