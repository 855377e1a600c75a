/* hc_lugre.h: one component's law of the library (components.h, SPEC §12.3): the paper's LuGre friction with
 * asymmetric static sets (SPEC §5, eq 25), the one source of its equations for the core (friction.c) and for
 * circuits (the lugre_cylinder). A static set per direction: Coulomb fc, breakaway fs, Stribeck velocity vs,
 * viscous kv [N, N, m/s, N.s/m]; the negative direction's forces are given as magnitudes. */
#ifndef HC_LUGRE_H
#define HC_LUGRE_H
#include "core.h"
#include "hh_exp.h"              /* (exp: the same bits on every platform) */

/* g(v) = fc + (fs - fc)*exp(-(v/vs)^2) [N] of the set of the direction of v (v >= 0: positive) */
HH_INLINE double hc_stribeck(double v, double fc_p, double fs_p, double vs_p, double fc_n, double fs_n, double vs_n)
{
    double r;
    if (v >= 0.0) {
        r = v / vs_p;
        return fc_p + (fs_p - fc_p) * hh_exp(-r * r);
    }
    r = v / vs_n;
    return fc_n + (fs_n - fc_n) * hh_exp(-r * r);
}

/* the steady-state (sliding) friction of eq 25 in a slip mode of one direction, of that direction's set [N]:
 * direction > 0: fc + (fs - fc)*exp(-(v/vs)^2) + kv*v; < 0: -(fc + (fs - fc)*exp(-(v/vs)^2)) + kv*v */
HH_INLINE double hc_slip_friction(double v, int direction, double fc, double fs, double vs, double kv)
{
    double r = v / vs;
    if (direction > 0)
        return fc + (fs - fc) * hh_exp(-r * r) + kv * v;
    return -(fc + (fs - fc) * hh_exp(-r * r)) + kv * v;
}

/* continuous LuGre: dz = v - sigma0*|v|*z/g(v), Ff = sigma0*z + sigma1*dz + kv*v (g and kv of v's direction) */
HH_INLINE double hc_lugre(double v, double z, double sigma0, double sigma1, double g, double kv, double *dz)
{
    *dz = v - sigma0 * fabs(v) * z / g;
    return sigma0 * z + sigma1 * *dz + kv * v;
}

#endif
