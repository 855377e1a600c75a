/* hybrid.c: the hybrid model's right-hand side, statechart and step, SPEC §6 (see hybrid.h). */
#include "hybrid.h"

/* dy/dt of the hybrid model in the modes m (SPEC §3-§6); sc: the step's stiff-chamber constants. */
HH_INLINE void hybrid_rhs(const double *y, double ud, const int64_t *m, const double *p, const double *sc,
                       double *dy)
{
    double vp, ff;
    spool_rhs(y[HH_XS], y[HH_VS], ud, p, &dy[HH_XS], &dy[HH_VS]);
    if (m[HH_M_TRAVEL] != HH_FREE) {
        vp = 0.0;
        dy[HH_XP] = 0.0;
        dy[HH_VP] = 0.0;
        dy[HH_Z] = 0.0;
    } else {
        vp = y[HH_VP];
        if (m[HH_M_FRICTION] == HH_STICK) {
            ff = p[HH_FRICTION_SIGMA0] * y[HH_Z] + (p[HH_FRICTION_SIGMA1] + viscous(vp, p)) * vp;
            dy[HH_Z] = vp;
        } else {
            ff = slip_friction(vp, m[HH_M_FRICTION] == HH_SLIP_POS ? 1 : -1, p);
            dy[HH_Z] = 0.0;
        }
        dy[HH_XP] = vp;
        dy[HH_VP] = (external_force(y[HH_P1], y[HH_P2], p) - ff) / p[HH_LOAD_MASS];
    }
    chamber_pressure_rates(y[HH_XS], y[HH_P1], y[HH_P2], y[HH_XP], vp, p, p[HH_VALVE_DP_LAMINAR], sc[0], sc[1],
                           &dy[HH_P1], &dy[HH_P2]);
    if (sc[2] != 0.0 || sc[3] != 0.0) {   /* a stiff chamber: its quasi-static pressure moves physically */
        double d1, d2;
        quasi_static_drift(y[HH_XS], dy[HH_XS], y[HH_P1], y[HH_P2], dy[HH_VP], p, p[HH_VALVE_DP_LAMINAR], &d1, &d2);
        dy[HH_P1] += sc[2] * d1;
        dy[HH_P2] += sc[3] * d2;
    }
}

/* Friction force [N] of the current state and modes (for logs; at a stop: the seal force s0*z). */
HH_INLINE double friction_force(const double *y, const int64_t *m, const double *p)
{
    if (m[HH_M_TRAVEL] != HH_FREE || m[HH_M_FRICTION] == HH_STICK) {
        double v = m[HH_M_TRAVEL] == HH_FREE ? y[HH_VP] : 0.0;
        return p[HH_FRICTION_SIGMA0] * y[HH_Z] + (p[HH_FRICTION_SIGMA1] + viscous(v, p)) * v;
    }
    return slip_friction(y[HH_VP], m[HH_M_FRICTION] == HH_SLIP_POS ? 1 : -1, p);
}

/* sc for the next step of size h (hybrid.h): [c1, c2, (1 - c1)/g1, (1 - c2)/g2], c_i in (0, 1] the
 * slowing of chamber i's relaxation, g_i = -dF_i/dP_i its conductance at the step start. */
HH_INLINE void stiff_chamber_constants(const double *y, const double *p, double h, double *sc)
{
    hh_sections s = pseudo_sections(y[HH_XS], p);
    double v1, v2, g1, g2, l1, l2, c1, c2, lim = p[HH_LAMBDA_H_MAX];
    double ps = p[HH_SUPPLY_PS], pt = p[HH_SUPPLY_PT], dl = p[HH_VALVE_DP_LAMINAR];
    volumes(y[HH_XP], p, &v1, &v2);
    g1 = orifice_slope(s.as1, ps - y[HH_P1], dl) + orifice_slope(s.a1t + p[HH_BURST1], y[HH_P1] - pt, dl)
         + p[HH_CYLINDER_G_LKC];
    g2 = orifice_slope(s.as2, ps - y[HH_P2], dl) + orifice_slope(s.a2t + p[HH_BURST2], y[HH_P2] - pt, dl)
         + p[HH_CYLINDER_G_LKC];
    l1 = bulk_modulus(y[HH_P1], 1, p) / v1 * g1 * h;
    l2 = bulk_modulus(y[HH_P2], 2, p) / v2 * g2 * h;
    c1 = hh_min(1.0, lim / l1);
    c2 = hh_min(1.0, lim / l2);
    sc[0] = c1;
    sc[1] = c2;
    sc[2] = c1 < 1.0 ? (1.0 - c1) / g1 : 0.0;
    sc[3] = c2 < 1.0 ? (1.0 - c2) / g2 : 0.0;
}

/* The guards and transitions of hybrid.h's table are the component library's LuGre cylinder's
 * (hc_lugre_cylinder.h: hc_lc_guard, hc_lc_reset; one copy of the stop, breakaway and reversal rules, which the
 * generated circuits use too) over its one mode: a piston on a stop, else its friction's (the core's two mode
 * slots map onto it; the guard ids and friction modes agree, checked here at compile time). */
#define HH_SAME(a, b) ((int)(a) == (int)(b))
typedef char hh_guards_are_the_library_s[(HH_SAME(HH_G_RETRACT, HC_LC_G_RETRACT) && HH_SAME(HH_G_EXTEND, HC_LC_G_EXTEND) &&
                                          HH_SAME(HH_G_BREAK_POS, HC_LC_G_BREAK_POS) && HH_SAME(HH_G_BREAK_NEG, HC_LC_G_BREAK_NEG) &&
                                          HH_SAME(HH_G_REVERSE, HC_LC_G_REVERSE) && HH_SAME(HH_G_LEAVE, HC_LC_G_LEAVE) &&
                                          HH_SAME(HH_STICK, HC_LC_STICK) && HH_SAME(HH_SLIP_POS, HC_LC_SLIP_POS) &&
                                          HH_SAME(HH_SLIP_NEG, HC_LC_SLIP_NEG)) ? 1 : -1];
#undef HH_SAME

HH_INLINE int lc_mode(const int64_t *m)
{
    return m[HH_M_TRAVEL] == HH_AT_RETRACT ? HC_LC_AT_RETRACT
         : m[HH_M_TRAVEL] == HH_AT_EXTEND ? HC_LC_AT_EXTEND : (int)m[HH_M_FRICTION];
}

/* Value of guard gid (>= 0 while the current mode is valid); +inf when it does not apply. */
HH_INLINE double guard_value(int gid, const double *y, const int64_t *m, const double *p)
{
    int mode = lc_mode(m);
    double f = mode >= HC_LC_AT_RETRACT ? external_force(y[HH_P1], y[HH_P2], p) : 0.0;   /* (leaving a stop only) */
    return hc_lc_guard(gid, mode, y[HH_XP], y[HH_VP], y[HH_Z], f, p[HH_CYLINDER_STROKE], p[HH_FRICTION_SIGMA0],
                       p[HH_FS_POS], p[HH_FS_NEG]);
}

/* Fraction of the step at which a guard going from g0 to g1 < 0 crosses zero (linear). */
HH_INLINE double crossing(double g0, double g1) { return g0 <= 0.0 ? 0.0 : g0 / (g0 - g1); }

/* (guard id, theta in [0, 1]) of the earliest guard crossing between y0 and y1, or HH_G_NONE. */
HH_INLINE int first_crossing(const double *y0, const double *y1, const int64_t *m, const double *p, double *theta)
{
    int best = HH_G_NONE, gid, g_lo, g_hi;
    double L = p[HH_CYLINDER_STROKE], g1;
    *theta = 1.0;
    if (m[HH_M_TRAVEL] != HH_FREE) {
        g1 = guard_value(HH_G_LEAVE, y1, m, p);
        if (g1 < 0.0) {
            *theta = crossing(guard_value(HH_G_LEAVE, y0, m, p), g1);
            return HH_G_LEAVE;
        }
        return best;
    }
    if (y1[HH_XP] < 0.0) {
        best = HH_G_RETRACT;
        *theta = crossing(y0[HH_XP], y1[HH_XP]);
    } else if (y1[HH_XP] > L) {
        best = HH_G_EXTEND;
        *theta = crossing(L - y0[HH_XP], L - y1[HH_XP]);
    }
    if (m[HH_M_FRICTION] == HH_STICK) {
        g_lo = HH_G_BREAK_POS;
        g_hi = HH_G_BREAK_NEG + 1;
    } else {
        g_lo = HH_G_REVERSE;
        g_hi = HH_G_REVERSE + 1;
    }
    for (gid = g_lo; gid < g_hi; gid++) {
        g1 = guard_value(gid, y1, m, p);
        if (g1 < 0.0) {
            double th = crossing(guard_value(gid, y0, m, p), g1);
            if (best == HH_G_NONE || th < *theta) {
                best = gid;
                *theta = th;
            }
        }
    }
    return best;
}

/* Discrete transition of guard gid (table in hybrid.h): the library's (hc_lc_reset), back in the two slots. */
HH_INLINE void apply_reset(int gid, double *y, int64_t *m, const double *p)
{
    int mode = hc_lc_reset(gid, lc_mode(m), &y[HH_XP], &y[HH_VP], &y[HH_Z], p[HH_CYLINDER_STROKE],
                           p[HH_FRICTION_SIGMA0], p[HH_FC_POS], p[HH_FS_POS], p[HH_VS_POS], p[HH_FC_NEG], p[HH_FS_NEG],
                           p[HH_VS_NEG]);
    m[HH_M_TRAVEL] = mode == HC_LC_AT_RETRACT ? HH_AT_RETRACT : mode == HC_LC_AT_EXTEND ? HH_AT_EXTEND : HH_FREE;
    m[HH_M_FRICTION] = mode >= HC_LC_AT_RETRACT ? HH_STICK : mode;
}

/* Keep the state on its mode's manifold and inside physical bounds after a (sub)step. */
HH_INLINE void project(double *y, const int64_t *m, const double *p)
{
    spool_project(&y[HH_XS], &y[HH_VS], p[HH_SPOOL_LV]);
    if (y[HH_P1] < HH_P_MIN)
        y[HH_P1] = HH_P_MIN;
    if (y[HH_P2] < HH_P_MIN)
        y[HH_P2] = HH_P_MIN;
    if (m[HH_M_TRAVEL] == HH_AT_RETRACT) {
        y[HH_XP] = 0.0;
        y[HH_VP] = 0.0;
    } else if (m[HH_M_TRAVEL] == HH_AT_EXTEND) {
        y[HH_XP] = p[HH_CYLINDER_STROKE];
        y[HH_VP] = 0.0;
    }
}

/* Spool region of the state at the end of a step (recorded, Fig 11b-style). */
HH_INLINE int spool_mode(const double *y, double ud, const double *p)
{
    return hc_spool_region(y[HH_XS], y[HH_VS], ud, p[HH_SPOOL_WN], p[HH_SPOOL_XI], p[HH_SPOOL_LA], p[HH_SPOOL_LV]);
}

/* One fixed step h of the hybrid model with tableau tab and delayed input ud; y, m in place; returns the
 * number of events located in the step (HH_MAX_EVENTS + 1: the budget was spent). */
HH_INLINE int hybrid_step_tab(const hh_tableau *tab, double *y, int64_t *m, const double *p, double ud, double h)
{
    double sc[4], y1[HH_NY], theta;
    double t_left = h;          /* time still to integrate in this step */
    double hs = h;              /* size of the next RK (sub)step */
    int pending = HH_G_NONE;    /* guard whose event instant the last substep was aimed at */
    int n_events = 0, it, gid, i;
    stiff_chamber_constants(y, p, h, sc);
    for (it = 0; it < 2 * HH_MAX_EVENTS + 1; it++) {
        rk_step(tab, hybrid_rhs, y, hs, ud, m, p, sc, y1);
        y1[HH_XS] = hh_unsubnormal(y1[HH_XS]);   /* the spool's and the piston's states without subnormal */
        y1[HH_VS] = hh_unsubnormal(y1[HH_VS]);   /* magnitudes (core.h), as a circuit's generated substep */
        y1[HH_XP] = hh_unsubnormal(y1[HH_XP]);
        y1[HH_VP] = hh_unsubnormal(y1[HH_VP]);
        y1[HH_Z] = hh_unsubnormal(y1[HH_Z]);
        project(y1, m, p);
        if (pending != HH_G_NONE) {   /* arrived at a located event: reset, go on in the new mode */
            for (i = 0; i < HH_NY; i++)
                y[i] = y1[i];
            apply_reset(pending, y, m, p);
            project(y, m, p);
            pending = HH_G_NONE;
            t_left -= hs;
            hs = t_left;
            if (t_left <= 1e-12 * h)
                break;
            continue;
        }
        gid = first_crossing(y, y1, m, p, &theta);
        if (gid == HH_G_NONE) {
            for (i = 0; i < HH_NY; i++)
                y[i] = y1[i];
            break;
        }
        n_events++;
        if (n_events > HH_MAX_EVENTS) {   /* event budget spent: take the step, reset at its end */
            for (i = 0; i < HH_NY; i++)
                y[i] = y1[i];
            apply_reset(gid, y, m, p);
            project(y, m, p);
            break;
        }
        if (theta <= 0.0) {               /* guard already violated at the start: reset now, redo the substep */
            apply_reset(gid, y, m, p);
            project(y, m, p);
            continue;
        }
        pending = gid;
        hs = theta * t_left;
    }
    m[HH_M_SPOOL] = spool_mode(y, ud, p);
    return n_events;
}

/* The hybrid step of each method, the tableau a compile-time constant of each. */
static int hybrid_step(int method, double *y, int64_t *m, const double *p, double ud, double h)
{
    switch (method) {
    case HH_EULER: return hybrid_step_tab(&HH_TABLEAUS[HH_EULER], y, m, p, ud, h);
    case HH_HEUN: return hybrid_step_tab(&HH_TABLEAUS[HH_HEUN], y, m, p, ud, h);
    case HH_RK4: return hybrid_step_tab(&HH_TABLEAUS[HH_RK4], y, m, p, ud, h);
    default: return hybrid_step_tab(&HH_TABLEAUS[HH_RK3], y, m, p, ud, h);
    }
}
