/* hc_lugre_cylinder.h: one component's law of the library (components.h, SPEC §12.3): the paper's differential
 * cylinder (SPEC §4-§6): chambers whose oil follows eq 21's pressure-dependent bulk modulus, internal leakage,
 * LuGre seal friction (hc_lugre.h) and end stops, as one statechart: the friction's stick and slip modes
 * (eq 25: breakaway at sigma0*z = Fs, stick again where the speed reverses) and the stops (plastic: at an end
 * until the net force pulls the piston off); its guards (below) let a circuit's step locate these events
 * inside the step, as the core's hybrid.c does. */
#ifndef HC_LUGRE_CYLINDER_H
#define HC_LUGRE_CYLINDER_H
#include "core.h"
#include "hc_lugre.h"

enum { HC_LC_STICK, HC_LC_SLIP_POS, HC_LC_SLIP_NEG, HC_LC_AT_RETRACT, HC_LC_AT_EXTEND };

/* effective bulk modulus [Pa] at gauge pressure p [Pa], eq 21: (1e5 + P)/(B*P + C), P floored at HH_P_MIN */
HH_INLINE double hc_bulk_modulus(double pressure, double b, double c)
{
    double pr = hh_max(pressure, HH_P_MIN);
    return (HH_P_ATM + pr) / (b * pr + c);
}

/* the position inside the stroke (the chambers' volumes) */
HH_INLINE double hc_in_stroke(double x, double stroke) { return hh_min(hh_max(x, 0.0), stroke); }

/* the seal friction [N] in mode `mode` at speed v, bristles z (at a stop: sigma0*z) */
HH_INLINE double hc_lc_friction(int mode, double v, double z, double sigma0, double sigma1, double fc_p, double fs_p,
                                double vs_p, double kv_p, double fc_n, double fs_n, double vs_n, double kv_n)
{
    if (mode == HC_LC_SLIP_POS)
        return hc_slip_friction(v, 1, fc_p, fs_p, vs_p, kv_p);
    if (mode == HC_LC_SLIP_NEG)
        return hc_slip_friction(v, -1, fc_n, fs_n, vs_n, kv_n);
    if (mode != HC_LC_STICK)
        return sigma0 * z;
    return sigma0 * z + (sigma1 + (v >= 0.0 ? kv_p : kv_n)) * v;
}

/* At rest (SPEC §12.5, the core's rest: loop.c): in stick the bristles carry the net force f on the still
 * piston (or motor), up to the breakaway force; elsewhere z as it is */
HH_INLINE double hc_lc_held_z(int mode, double f, double z, double sigma0, double fs_p, double fs_n)
{
    return mode == HC_LC_STICK ? hh_min(hh_max(f, -fs_n), fs_p) / sigma0 : z;
}

/* At rest (the core's rest, loop.c): a piston at or beyond an end with the net force f pushing it there rests
 * on that stop (x, v clamped); a free one stays in its mode */
HH_INLINE int hc_lc_rest_mode(int mode, double *x, double *v, double f, double stroke)
{
    if (mode == HC_LC_AT_RETRACT || mode == HC_LC_AT_EXTEND)
        return mode;
    if (*x <= 0.0 && f <= 0.0) {
        *x = 0.0;
        *v = 0.0;
        return HC_LC_AT_RETRACT;
    }
    if (*x >= stroke && f >= 0.0) {
        *x = stroke;
        *v = 0.0;
        return HC_LC_AT_EXTEND;
    }
    return mode;
}

/* ---- its events as data

 (SPEC §6, the guards of hybrid.c's statechart): guard g's value is >= 0 while the mode
 * it belongs to holds (+inf in the other modes), so that a generated step locates the earliest crossing inside
 * the step (the circuit's first_crossing) and applies the guard's reset there. A rotary motion (lugre_motor)
 * uses the friction's three only. */
enum { HC_LC_G_RETRACT, HC_LC_G_EXTEND, HC_LC_G_BREAK_POS, HC_LC_G_BREAK_NEG, HC_LC_G_REVERSE, HC_LC_G_LEAVE };

/* guard g in mode `mode` at (x, v, z); f the net force on the piston without friction [N] */
HH_INLINE double hc_lc_guard(int g, int mode, double x, double v, double z, double f, double stroke, double sigma0,
                             double fs_p, double fs_n)
{
    if (mode == HC_LC_AT_RETRACT || mode == HC_LC_AT_EXTEND) {     /* pulled off its stop by the net force */
        if (g != HC_LC_G_LEAVE)
            return INFINITY;
        return mode == HC_LC_AT_RETRACT ? -(f - sigma0 * z) : f - sigma0 * z;
    }
    if (g == HC_LC_G_RETRACT)
        return x;
    if (g == HC_LC_G_EXTEND)
        return stroke - x;
    if (g == HC_LC_G_BREAK_POS && mode == HC_LC_STICK)
        return fs_p - sigma0 * z;
    if (g == HC_LC_G_BREAK_NEG && mode == HC_LC_STICK)
        return fs_n + sigma0 * z;
    if (g == HC_LC_G_REVERSE && mode != HC_LC_STICK)
        return mode == HC_LC_SLIP_POS ? v : -v;
    return INFINITY;
}

/* the friction's transitions (breakaway either way, sticking again where the speed reverses: v = 0, the
 * bristles at the breakaway's deflection); v, z in place; returns the new mode. A linear or rotary motion. */
HH_INLINE int hc_lc_friction_reset(int g, int mode, double *v, double *z, double sigma0, double fs_p, double fs_n)
{
    double d;
    if (g == HC_LC_G_BREAK_POS)
        return HC_LC_SLIP_POS;
    if (g == HC_LC_G_BREAK_NEG)
        return HC_LC_SLIP_NEG;
    d = mode == HC_LC_SLIP_POS ? 1.0 : -1.0;             /* reverse */
    *v = 0.0;
    *z = d * (d > 0 ? fs_p : fs_n) / sigma0;
    return HC_LC_STICK;
}

/* the transition of guard g (hybrid.c's apply_reset): x, v, z in place; returns the new mode */
HH_INLINE int hc_lc_reset(int g, int mode, double *x, double *v, double *z, double stroke, double sigma0,
                          double fc_p, double fs_p, double vs_p, double fc_n, double fs_n, double vs_n)
{
    double d;
    if (g == HC_LC_G_RETRACT || g == HC_LC_G_EXTEND) {   /* plastic stop, the bristles at their sliding state */
        if (mode != HC_LC_STICK) {
            d = mode == HC_LC_SLIP_POS ? 1.0 : -1.0;
            *z = d * hc_stribeck(*v, fc_p, fs_p, vs_p, fc_n, fs_n, vs_n) / sigma0;
        }
        *x = g == HC_LC_G_RETRACT ? 0.0 : stroke;
        *v = 0.0;
        return g == HC_LC_G_RETRACT ? HC_LC_AT_RETRACT : HC_LC_AT_EXTEND;
    }
    if (g == HC_LC_G_LEAVE)
        return HC_LC_STICK;                              /* free, the bristles holding */
    return hc_lc_friction_reset(g, mode, v, z, sigma0, fs_p, fs_n);
}

/* The statecharts as a whole (a circuit's modes at the start and in the rest march, where no step locates
 * the events): the first of its guards violated, its transition; x, v, z in place. A piston on a stop stays
 * clamped there. The cylinder's: every guard; a rotary motion's (lugre_motor): the friction's. */
HH_INLINE int hc_lc_mode(int mode, double *x, double *v, double *z, double f, double stroke, double sigma0,
                         double fc_p, double fs_p, double vs_p, double fc_n, double fs_n, double vs_n)
{
    int g;
    if (mode == HC_LC_AT_RETRACT || mode == HC_LC_AT_EXTEND) {
        *x = mode == HC_LC_AT_RETRACT ? 0.0 : stroke;
        *v = 0.0;
    }
    for (g = HC_LC_G_RETRACT; g <= HC_LC_G_LEAVE; g++)
        if (hc_lc_guard(g, mode, *x, *v, *z, f, stroke, sigma0, fs_p, fs_n) < 0.0)
            return hc_lc_reset(g, mode, x, v, z, stroke, sigma0, fc_p, fs_p, vs_p, fc_n, fs_n, vs_n);
    return mode;
}

HH_INLINE int hc_lc_friction_mode(int mode, double *v, double *z, double sigma0, double fs_p, double fs_n)
{
    int g;
    for (g = HC_LC_G_BREAK_POS; g <= HC_LC_G_REVERSE; g++)
        if (hc_lc_guard(g, mode, 0.0, *v, *z, 0.0, INFINITY, sigma0, fs_p, fs_n) < 0.0)
            return hc_lc_friction_reset(g, mode, v, z, sigma0, fs_p, fs_n);
    return mode;
}

#endif
