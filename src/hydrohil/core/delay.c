/* delay.c: fractional input delay (see delay.h). */
#include "delay.h"

#ifndef HH_CORE_LINKED   /* (hh.h's functions of this part; a translation unit linked with hh_core.c, which defines
                           them, leaves them out: core.h) */
int hh_delay_steps(double delay, double h, double *alpha)
{
    double r = delay / h;
    int n = (int)floor(r + 1e-9);
    *alpha = hh_max(0.0, r - n);
    return n;
}

void hh_delay_init(hh_delay *d, double *buf, int n, double alpha, double u0)
{
    int i;
    d->buf = buf;
    d->size = n + 2;
    d->pos = 0;
    d->n = n;
    d->alpha = alpha;
    for (i = 0; i < d->size; i++)
        buf[i] = u0;
}
#endif

/* Push the command u of this step; returns the delayed spool input of the step (the step average of the
 * two held commands it straddles, u_{k-n} and u_{k-n-1}, also returned). The ring's indices wrap by one
 * comparison each, no division (0 <= pos < size = n + 2: pos - n - 1 > -size); the same entries as the
 * remainders' ((pos - n) % size + size) % size, and three integer divisions fewer on the step's path to the
 * spool (issue #29). */
static double delay_push(hh_delay *d, double u, double *u_new, double *u_old)
{
    int size = d->size, pos = d->pos + 1, i_new, i_old;
    if (pos == size)
        pos = 0;
    d->pos = pos;
    d->buf[pos] = u;
    i_new = pos - d->n;
    if (i_new < 0)
        i_new += size;
    i_old = i_new == 0 ? size - 1 : i_new - 1;
    *u_new = d->buf[i_new];
    *u_old = d->buf[i_old];
    return (1.0 - d->alpha) * *u_new + d->alpha * *u_old;
}

/* The spool's input if u were pushed into the delay line now; the line is left as it was. */
static double delay_peek(hh_delay *d, double u)
{
    int pos = d->pos, next = pos + 1 == d->size ? 0 : pos + 1;
    double overwritten = d->buf[next], u_new, u_old, ud = delay_push(d, u, &u_new, &u_old);
    d->buf[next] = overwritten;
    d->pos = pos;
    return ud;
}
