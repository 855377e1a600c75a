/* hc_load.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_LOAD_H
#define HC_LOAD_H
#include "core.h"

/* A load's force table: f(x) linear between the n points (xs increasing), held beyond the first and the last
 * (a workpiece met by a press, a spring's measured curve) */
HH_INLINE double hc_table(double x, const double *xs, const double *fs, int n)
{
    int i;
    if (x <= xs[0])
        return fs[0];
    for (i = 1; i < n; i++)
        if (x < xs[i])
            return fs[i - 1] + (fs[i] - fs[i - 1]) * (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    return fs[n - 1];
}

#endif
