/* rest.c: the plant at rest (SPEC §12.5, §7). The chamber pressures at which both chambers' net inflows
 * vanish at a spool position (the valve's flows of SPEC §3.2 with their laminar region, and the internal
 * leakage of eq 22), and the spool offset at which those pressures hold the piston (eq 28 with vp = 0 and
 * no friction). The default initial state of every layer (hh_initial_state: simulate, the rig, both HIL
 * plants, the FMU) and the operating point of the linearisation (linear.py) come from here. */
#include <float.h>
#include "cylinder.h"

#define REST_TOL_P 1e-6      /* Pa: the pressures' root tolerance */
#define REST_TOL_XS 1e-14    /* the spool offset's root tolerance */
#define ZERO_IN_MAX 200      /* evaluations per root at most (Brent's method converges in ~10-40) */

typedef double (*rest_fn)(double, void *);

/* A root of f in [a, b] (f(a), f(b) of opposite signs, or one of them 0) to within tol, by Brent's method
 * (bisection, secant and inverse quadratic interpolation; R. Brent, Algorithms for minimization without
 * derivatives, 1973, ch. 4). Bounded work: at most ZERO_IN_MAX evaluations. */
static double zero_in(rest_fn f, void *ctx, double a, double b, double tol)
{
    double fa = f(a, ctx), fb = f(b, ctx), c, fc, d, e, m, p, q, r, s, t;
    int it;
    if (fa == 0.0)
        return a;
    if (fb == 0.0)
        return b;
    c = a;
    fc = fa;
    d = e = b - a;
    for (it = 0; it < ZERO_IN_MAX; it++) {
        if ((fb > 0.0) == (fc > 0.0)) {          /* keep the root between b and c */
            c = a;
            fc = fa;
            d = e = b - a;
        }
        if (fabs(fc) < fabs(fb)) {                /* b the best estimate */
            a = b;
            b = c;
            c = a;
            fa = fb;
            fb = fc;
            fc = fa;
        }
        t = 2.0 * DBL_EPSILON * fabs(b) + 0.5 * tol;
        m = 0.5 * (c - b);
        if (fabs(m) <= t || fb == 0.0)
            return b;
        if (fabs(e) < t || fabs(fa) <= fabs(fb)) {
            d = e = m;                            /* bisection */
        } else {
            s = fb / fa;
            if (a == c) {                         /* secant */
                p = 2.0 * m * s;
                q = 1.0 - s;
            } else {                              /* inverse quadratic interpolation */
                q = fa / fc;
                r = fb / fc;
                p = s * (2.0 * m * q * (q - r) - (b - a) * (r - 1.0));
                q = (q - 1.0) * (r - 1.0) * (s - 1.0);
            }
            if (p > 0.0)
                q = -q;
            else
                p = -p;
            if (2.0 * p < 3.0 * m * q - fabs(t * q) && p < fabs(0.5 * e * q)) {
                e = d;
                d = p / q;
            } else {
                d = e = m;
            }
        }
        a = b;
        fa = fb;
        b += fabs(d) > t ? d : (m > 0.0 ? t : -t);
        fb = f(b, ctx);
    }
    return b;
}

typedef struct {
    const double *p;
    double xs, p1, p2;
} rest_ctx;

/* Net inflow [m^3/s] of chamber 2 at pressure p2 (p1 held): decreasing in p2. */
static double chamber2_inflow(double p2, void *ctx)
{
    rest_ctx *c = ctx;
    double q1, q2;
    valve_flows(c->xs, c->p1, p2, c->p, c->p[HH_VALVE_DP_LAMINAR], &q1, &q2);
    return q2 + c->p[HH_CYLINDER_G_LKC] * (c->p1 - p2);
}

/* Net inflow of chamber 1 at pressure p1 with chamber 2 balanced for it: decreasing in p1 (p2 rises with
 * p1 by g/(g + its valve conductance) <= 1, so the leakage p1 - p2 does not fall). */
static double chamber1_inflow(double p1, void *ctx)
{
    rest_ctx *c = ctx;
    double q1, q2, ps = c->p[HH_SUPPLY_PS], pt = c->p[HH_SUPPLY_PT];
    c->p1 = p1;
    c->p2 = zero_in(chamber2_inflow, c, pt, ps, REST_TOL_P);
    valve_flows(c->xs, p1, c->p2, c->p, c->p[HH_VALVE_DP_LAMINAR], &q1, &q2);
    return q1 - c->p[HH_CYLINDER_G_LKC] * (p1 - c->p2);
}

void hh_rest_pressures(const double *p, double xs, double *p1, double *p2)
{
    rest_ctx c;
    c.p = p;
    c.xs = xs;
    c.p1 = c.p2 = 0.0;
    *p1 = zero_in(chamber1_inflow, &c, p[HH_SUPPLY_PT], p[HH_SUPPLY_PS], REST_TOL_P);
    c.p1 = *p1;
    *p2 = zero_in(chamber2_inflow, &c, p[HH_SUPPLY_PT], p[HH_SUPPLY_PS], REST_TOL_P);
}

/* Force on the piston [N] at rest with the spool at xs (increasing in xs: p1 rises, p2 falls). */
static double rest_force(double xs, void *ctx)
{
    double p1, p2;
    hh_rest_pressures(ctx, xs, &p1, &p2);
    return external_force(p1, p2, ctx);
}

int hh_rest_state(const double *p, double *xs, double *p1, double *p2)
{
    void *ctx = (void *)p;
    int held = rest_force(-1.0, ctx) <= 0.0 && rest_force(1.0, ctx) >= 0.0;
    *xs = held ? zero_in(rest_force, ctx, -1.0, 1.0, REST_TOL_XS) : 0.0;
    hh_rest_pressures(p, *xs, p1, p2);
    return held ? 0 : -1;
}
