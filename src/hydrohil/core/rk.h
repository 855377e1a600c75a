/* rk.h: the one explicit Runge-Kutta stepper; each fixed-step method is its Butcher tableau. */
#ifndef HH_RK_H
#define HH_RK_H
#include "core.h"

#define HH_MAX_STAGES 4

typedef struct {
    const char *name;
    int order, stages;
    double a[HH_MAX_STAGES][HH_MAX_STAGES];   /* strictly lower triangular */
    double b[HH_MAX_STAGES];
    double real_axis_limit;                   /* stability interval on the negative real axis, |lambda*h| */
} hh_tableau;

/* A model right-hand side: dy/dt at y under spool input ud in the modes m; sc: per-step constants. */
typedef void (*hh_rhs)(const double *y, double ud, const int64_t *m, const double *p, const double *sc,
                       double *dy);

static const hh_tableau HH_TABLEAUS[HH_NMETHODS];

#endif
