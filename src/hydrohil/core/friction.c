/* friction.c: LuGre friction, SPEC §5 (see friction.h); the equations are the library's (hc_lugre.h). */
#include "friction.h"

/* g(v) = Fc + (Fs - Fc)*exp(-(v/vs)^2) [N] with the set of the direction of v (v >= 0: positive). */
HH_INLINE double stribeck(double v, const double *p)
{
    return hc_stribeck(v, p[HH_FC_POS], p[HH_FS_POS], p[HH_VS_POS], p[HH_FC_NEG], p[HH_FS_NEG], p[HH_VS_NEG]);
}

/* Viscous coefficient Kv [N.s/m] of the direction of v. */
HH_INLINE double viscous(double v, const double *p) { return v >= 0.0 ? p[HH_KV_POS] : p[HH_KV_NEG]; }

/* Steady-state (sliding) friction of eq 25 in a slip mode of the given direction (+1/-1) [N]. */
HH_INLINE double slip_friction(double v, int direction, const double *p)
{
    if (direction > 0)
        return hc_slip_friction(v, 1, p[HH_FC_POS], p[HH_FS_POS], p[HH_VS_POS], p[HH_KV_POS]);
    return hc_slip_friction(v, -1, p[HH_FC_NEG], p[HH_FS_NEG], p[HH_VS_NEG], p[HH_KV_NEG]);
}

/* Continuous LuGre (SPEC §5): dz = v - sigma0*|v|*z/g(v), Ff = sigma0*z + sigma1*dz + Kv*v; returns Ff. */
HH_INLINE double lugre(double v, double z, const double *p, double *dz)
{
    return hc_lugre(v, z, p[HH_FRICTION_SIGMA0], p[HH_FRICTION_SIGMA1], stribeck(v, p), viscous(v, p), dz);
}
