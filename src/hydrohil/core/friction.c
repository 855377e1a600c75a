/* friction.c: LuGre friction, SPEC §5 (see friction.h). */
#include "friction.h"

/* g(v) = Fc + (Fs - Fc)*exp(-(v/vs)^2) [N] with the set of the direction of v (v >= 0: positive). */
HH_INLINE double stribeck(double v, const double *p)
{
    double r;
    if (v >= 0.0) {
        r = v / p[HH_VS_POS];
        return p[HH_FC_POS] + (p[HH_FS_POS] - p[HH_FC_POS]) * exp(-r * r);
    }
    r = v / p[HH_VS_NEG];
    return p[HH_FC_NEG] + (p[HH_FS_NEG] - p[HH_FC_NEG]) * exp(-r * r);
}

/* Viscous coefficient Kv [N.s/m] of the direction of v. */
HH_INLINE double viscous(double v, const double *p) { return v >= 0.0 ? p[HH_KV_POS] : p[HH_KV_NEG]; }

/* Steady-state (sliding) friction of eq 25 in a slip mode of the given direction (+1/-1) [N]. */
HH_INLINE double slip_friction(double v, int direction, const double *p)
{
    double r;
    if (direction > 0) {
        r = v / p[HH_VS_POS];
        return p[HH_FC_POS] + (p[HH_FS_POS] - p[HH_FC_POS]) * exp(-r * r) + p[HH_KV_POS] * v;
    }
    r = v / p[HH_VS_NEG];
    return -(p[HH_FC_NEG] + (p[HH_FS_NEG] - p[HH_FC_NEG]) * exp(-r * r)) + p[HH_KV_NEG] * v;
}

/* Continuous LuGre (SPEC §5): dz = v - sigma0*|v|*z/g(v), Ff = sigma0*z + sigma1*dz + Kv*v; returns Ff. */
HH_INLINE double lugre(double v, double z, const double *p, double *dz)
{
    *dz = v - p[HH_FRICTION_SIGMA0] * fabs(v) * z / stribeck(v, p);
    return p[HH_FRICTION_SIGMA0] * z + p[HH_FRICTION_SIGMA1] * *dz + viscous(v, p) * v;
}
