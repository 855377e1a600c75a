/* spool_bode.c: periodic steady state of the spool model under a sine, as a datasheet Bode point shows it
 * (SPEC §3.1, §9.1; paper eq 1-2). The batch work of spool identification (identification/spool.py): the
 * fit, its report curves and every synthetic data generator evaluate the model only here.
 *
 * The model is the plant's spool (spool_rhs and spool_project of valve.c: eq 1, its limits, its ends). It is
 * odd (spool_rhs(-x, -v, -u) = -spool_rhs(x, v, u): symmetric limits and ends) and
 * u(t + T/2) = -u(t), so a period is two applications of the half-period map H(s) = -Phi_{T/2}(s) of
 * s = (x̄s, v̄s), and a half-wave symmetric periodic response is a fixed point of H. The method and its
 * measured accuracy are described at hh_steady_sine_response below and in identification/spool.py. */
#include "valve.h"

#define H_MAX 2e-5                  /* s, largest internal RK4 step */
#define STEPS_PER_PERIOD_MIN 200    /* made even: the steady state is computed half a period at a time */
#define STEADY_TOL 1e-9             /* periodic: a half period ends where it began (sign flipped) within this */
#define REFINE_DEPTH 10             /* a step holding a discontinuity of the model is cut down to h/2^10 */
#define ACCEL_HALF_PERIODS 100      /* at most these for the accelerated half-period search */
#define PLAIN_HALF_PERIODS 6        /* simulated as they come before the slow tail may be accelerated */
#define SLOW_CONTRACTION 0.2        /* tail accelerated when a half period shrinks the residual by < 5x */

static const double HH_PI = 3.141592653589793;
const double hh_spool_steady_tol = STEADY_TOL;

/* RK4 steps per period at freq [Hz]: h <= H_MAX, at least STEPS_PER_PERIOD_MIN, even. */
static int64_t steps_per_period(double freq)
{
    int64_t spp = (int64_t)ceil(1.0 / (freq * H_MAX));
    if (spp < STEPS_PER_PERIOD_MIN)
        spp = STEPS_PER_PERIOD_MIN;
    return spp + (spp & 1);
}

int64_t hh_spool_bode_work(double freq) { return 3 * steps_per_period(freq) + 4; }

/* The limits across which the right-hand side is discontinuous: the limited integrator at ±Lv and the
 * spool's ends (the acceleration clamp at ±La is continuous). */
#define JUMPS (HH_SPOOL_ACTS_VEL | HH_SPOOL_ACTS_END)

/* One classic RK4 step of the plant's spool (spool_rhs: eq 1, its limits and its ends) with the input at t,
 * t + h/2, t + h, then the plant's projection (spool_project: velocity held in ±Lv, ends plastic).
 * *switched: the step holds a discontinuity of the model (its stages not all on one side of one, or the
 * projection acted); returns the limits that acted in it (HH_SPOOL_ACTS_* bits). */
HH_INLINE int spool_rk4(const double *p, double *xs, double *vs, double u0, double um, double u1, double h,
                        double lv, int *switched)
{
    double d1x, d1v, d2x, d2v, d3x, d3v, d4x, d4v, xn, vn;
    int m1, m2, m3, m4, clipped = 0;
    m1 = spool_rhs(*xs, *vs, u0, p, &d1x, &d1v);
    m2 = spool_rhs(*xs + 0.5 * h * d1x, *vs + 0.5 * h * d1v, um, p, &d2x, &d2v);
    m3 = spool_rhs(*xs + 0.5 * h * d2x, *vs + 0.5 * h * d2v, um, p, &d3x, &d3v);
    m4 = spool_rhs(*xs + h * d3x, *vs + h * d3v, u1, p, &d4x, &d4v);
    xn = *xs + h / 6.0 * (d1x + 2.0 * d2x + 2.0 * d3x + d4x);
    vn = *vs + h / 6.0 * (d1v + 2.0 * d2v + 2.0 * d3v + d4v);
    if (vn > lv || vn < -lv)
        clipped |= HH_SPOOL_ACTS_VEL;
    if (xn > 1.0 || xn < -1.0)
        clipped |= HH_SPOOL_ACTS_END;
    spool_project(&xn, &vn, lv);
    *switched = (m2 & JUMPS) != (m1 & JUMPS) || (m3 & JUMPS) != (m1 & JUMPS) || (m4 & JUMPS) != (m1 & JUMPS)
                || clipped;
    *xs = xn;
    *vs = vn;
    return m1 | m2 | m3 | m4 | clipped;
}

/* The step [t0, t0 + h] that holds a discontinuity, as dyadic sub-steps: a sub-step that still holds one is
 * halved, down to h/2^REFINE_DEPTH. A fixed-step RK4 across the discontinuous right-hand side of the
 * velocity limit makes the state jump by ~h^2*La as the switching crosses a stage; this leaves jumps
 * ~4^-REFINE_DEPTH times smaller, so the steady state and the fit's cost are smooth. */
static int refined_step(const double *p, double amplitude, double w, double t0, double h, double *xs, double *vs,
                        double lv)
{
    const int64_t full = (int64_t)1 << REFINE_DEPTH;
    int64_t pos = 0, size;
    int level = 1, switched, acts = 0;
    while (pos < full) {
        double hs, ts, xn = *xs, vn = *vs;
        int step_acts;
        size = full >> level;
        hs = h * (double)size / (double)full;
        ts = t0 + h * (double)pos / (double)full;
        step_acts = spool_rk4(p, &xn, &vn, amplitude * sin(w * ts), amplitude * sin(w * (ts + 0.5 * hs)),
                              amplitude * sin(w * (ts + hs)), hs, lv, &switched);
        if (switched && level < REFINE_DEPTH) {
            level++;
            continue;
        }
        acts |= step_acts;
        *xs = xn;
        *vs = vn;
        pos += size;
        while (level > 1 && pos % (2 * size) == 0) {   /* back to the coarser sub-step once aligned with it */
            level--;
            size *= 2;
        }
    }
    return acts;
}

/* RK4 over half a period of u = amplitude*sin(wt) from (xs, vs) at t = 0; sin_tab[i] = sin(wt) at t = i*h/2;
 * xbuf[j] receives x̄s at t = j*h (j = 0..n). Returns the limits that acted (HH_SPOOL_ACTS_* bits); pk: the
 * largest |x̄s|, |v̄s| and |a*| (the demanded acceleration ωn²(u − x̄s) − 2ξωn·v̄s before its clamp) at the
 * step ends. */
static int half_period(const double *p, double amplitude, const double *sin_tab, double w, double h, int64_t n,
                       double *xs, double *vs, double *xbuf, double pk[3])
{
    double lv = p[HH_SPOOL_LV], wn = p[HH_SPOOL_WN], c = 2.0 * p[HH_SPOOL_XI] * p[HH_SPOOL_WN];
    double x = *xs, v = *vs;
    int acts = 0, switched, step_acts;
    int64_t j;
    xbuf[0] = x;
    pk[0] = fabs(x);
    pk[1] = fabs(v);
    pk[2] = 0.0;
    for (j = 0; j < n; j++) {
        double xn = x, vn = v;
        step_acts = spool_rk4(p, &xn, &vn, amplitude * sin_tab[2 * j], amplitude * sin_tab[2 * j + 1],
                              amplitude * sin_tab[2 * j + 2], h, lv, &switched);
        if (switched) {
            xn = x;
            vn = v;
            step_acts = refined_step(p, amplitude, w, (double)j * h, h, &xn, &vn, lv);
        }
        acts |= step_acts;
        x = xn;
        v = vn;
        xbuf[j + 1] = x;
        pk[0] = hh_max(pk[0], fabs(x));
        pk[1] = hh_max(pk[1], fabs(v));
        pk[2] = hh_max(pk[2], fabs(wn * wn * (amplitude * sin_tab[2 * j + 2] - x) - c * v));
    }
    *xs = x;
    *vs = v;
    return acts;
}

/* Sample k (cyclic) of one period made of the half period xa then the negation of xb. */
HH_INLINE double period_sample(const double *xa, const double *xb, int64_t n, int64_t k)
{
    k = ((k % (2 * n)) + 2 * n) % (2 * n);
    return k < n ? xa[k] : -xb[k - n];
}

/* Extreme of the parabola through three equally spaced samples (y0 if they are collinear). */
HH_INLINE double parabola_peak(double ym, double y0, double yp)
{
    double curv = ym - 2.0 * y0 + yp;
    return curv == 0.0 ? y0 : y0 - 0.125 * (ym - yp) * (ym - yp) / curv;
}

/* (half peak-to-peak, phase of the fundamental [rad]) of x̄s over one period: the half period xa (in the
 * frame of u = A sin wt) then xb simulated in the negated frame; extremes refined by a parabola, within the
 * spool's ends. */
static void amplitude_and_phase(const double *xa, const double *xb, int64_t n, const double *sin_tab,
                                const double *cos_tab, double *a_out, double *phase)
{
    int64_t k, kmax = 0, kmin = 0, j;
    double hi, lo, c_sin = 0.0, c_cos = 0.0;
    for (k = 1; k < 2 * n; k++) {
        double y = period_sample(xa, xb, n, k);
        if (y > period_sample(xa, xb, n, kmax))
            kmax = k;
        if (y < period_sample(xa, xb, n, kmin))
            kmin = k;
    }
    hi = parabola_peak(period_sample(xa, xb, n, kmax - 1), period_sample(xa, xb, n, kmax),
                       period_sample(xa, xb, n, kmax + 1));
    lo = parabola_peak(period_sample(xa, xb, n, kmin - 1), period_sample(xa, xb, n, kmin),
                       period_sample(xa, xb, n, kmin + 1));
    hi = hh_min(hi, 1.0);   /* a peak at an end is a kink (the plastic stop), not a parabola's vertex */
    lo = hh_max(lo, -1.0);
    for (j = 0; j < n; j++) {   /* second half: (-xb)*(-sin), (-xb)*(-cos) */
        c_sin += (xa[j] + xb[j]) * sin_tab[2 * j];
        c_cos += (xa[j] + xb[j]) * cos_tab[2 * j];
    }
    *a_out = 0.5 * (hi - lo);
    *phase = atan2(c_cos, c_sin);
}

/* Periodic steady state under u = amplitude*sin(2 pi f t): output half peak-to-peak, phase of the
 * fundamental [rad], half periods simulated, residual (estimated distance to the periodic state relative
 * to the output amplitude; > tol when max_half_periods was hit).
 * 1. From rest, half periods until one ends where it began (sign flipped): |H(s) - s| <= tol*A_out in
 *    (x̄s, v̄s/w). The first PLAIN_HALF_PERIODS as they come; then, while a half period shrinks the
 *    residual by less than 1/SLOW_CONTRACTION, each next start is extrapolated by a secant step through
 *    the last two iterates (Anderson mixing, memory 1). A fixed point reached by extrapolation is accepted
 *    only if it attracts (spectral radius of H's Jacobian by finite differences < 1).
 * 2. Otherwise the sine from rest period by period until two successive periods agree: the difference d_k
 *    of successive period starts with the contraction l = d_k/d_{k-1} bounds the distance to the periodic
 *    state by d_k*max(1, l/(1 - l)) <= tol. Amplitude and phase: those of the last simulated period. */
static void steady_sine_response(const double *p, double amplitude, double freq, int64_t spp, double tol,
                                 int64_t max_half_periods, double *work, double *a_out, double *ph,
                                 int64_t *used_out, double *resid_out, int64_t *acts_out, double *peaks_out)
{
    int64_t n = spp / 2, i, it, used = 0, it_max;
    double h = 1.0 / (freq * (double)spp), w = 2.0 * HH_PI * freq, lv = p[HH_SPOOL_LV];
    double *sin_tab = work, *cos_tab = work + spp + 1, *xa = work + 2 * (spp + 1), *xb = xa + n + 1;
    double x = 0.0, v = 0.0, px = 0.0, pv = 0.0, pfx = 0.0, pfv = 0.0, r_prev = INFINITY, d_prev, err;
    int accel = 0;
    for (i = 0; i <= spp; i++) {
        sin_tab[i] = sin(HH_PI * (double)i / (double)spp);
        cos_tab[i] = cos(HH_PI * (double)i / (double)spp);
    }
    /* 1. the sine from rest, half period by half period; the slow tail secant-accelerated */
    it_max = max_half_periods - 2 < ACCEL_HALF_PERIODS ? max_half_periods - 2 : ACCEL_HALF_PERIODS;
    for (it = 1; it <= it_max; it++) {
        double ex = x, ev = v, pk[3], gx, gv, fx, fv, resid, nx, nv, peak;
        int acts = half_period(p, amplitude, sin_tab, w, h, n, &ex, &ev, xa, pk);
        used++;
        gx = -ex;
        gv = -ev;
        fx = gx - x;
        fv = (gv - v) / w;
        peak = pk[0];
        resid = sqrt(fx * fx + fv * fv) / hh_max(peak, 1e-300);
        if (resid <= tol) {
            double d, e1x, e1v, e2x, e2v, j11, j21, j12, j22, tr, det, disc, rho;
            amplitude_and_phase(xa, xa, n, sin_tab, cos_tab, a_out, ph);
            *acts_out = acts;              /* the other half period is its mirror image */
            peaks_out[0] = pk[1];
            peaks_out[1] = pk[2];
            if (!(accel && acts)) {        /* reached by simulation, or the model was linear */
                *used_out = used;
                *resid_out = resid;
                return;
            }
            d = 1e-6 * peak;               /* Jacobian of H in (x, v/w), forward differences */
            e1x = x + d;
            e1v = v;
            half_period(p, amplitude, sin_tab, w, h, n, &e1x, &e1v, xb, pk);
            e2x = x;
            e2v = v + d * w;
            half_period(p, amplitude, sin_tab, w, h, n, &e2x, &e2v, xb, pk);
            used += 2;
            j11 = (-e1x - gx) / d;
            j21 = (-e1v - gv) / (w * d);
            j12 = (-e2x - gx) / d;
            j22 = (-e2v - gv) / (w * d);
            tr = j11 + j22;
            det = j11 * j22 - j12 * j21;
            disc = tr * tr - 4.0 * det;
            rho = disc >= 0.0 ? 0.5 * (fabs(tr) + sqrt(disc)) : sqrt(fabs(det));
            if (rho < 1.0) {
                *used_out = used;
                *resid_out = resid;
                return;
            }
            break;
        }
        if (it >= PLAIN_HALF_PERIODS && resid > SLOW_CONTRACTION * r_prev)
            accel = 1;
        nx = gx;
        nv = gv;
        if (accel) {                       /* secant (Anderson-1) step on f(s) = H(s) - s, scaled (x, v/w) */
            double dfx = fx - pfx, dfv = fv - pfv, den = dfx * dfx + dfv * dfv;
            if (den > 0.0) {
                double gam = (fx * dfx + fv * dfv) / den;
                nx = gx - gam * ((x - px) + dfx);
                nv = gv - gam * ((v - pv) + dfv * w);
            }
        }
        px = x;
        pv = v;
        pfx = fx;
        pfv = fv;
        r_prev = resid;
        x = nx;
        v = hh_min(hh_max(nv, -lv), lv);
    }
    /* 2. plain simulation from rest, period by period, until two successive periods agree */
    x = 0.0;
    v = 0.0;
    d_prev = INFINITY;
    *acts_out = 0;
    peaks_out[0] = peaks_out[1] = 0.0;
    *a_out = 0.0;
    *ph = 0.0;
    err = INFINITY;
    while (used + 2 <= max_half_periods) {
        double mx = x, mv = v, ex, ev, pk[3], pk2[3], dx, dv, d, lam;
        *acts_out = half_period(p, amplitude, sin_tab, w, h, n, &mx, &mv, xa, pk);
        ex = -mx;
        ev = -mv;
        *acts_out |= half_period(p, amplitude, sin_tab, w, h, n, &ex, &ev, xb, pk2);   /* = H(H(s)) negated */
        peaks_out[0] = hh_max(pk[1], pk2[1]);
        peaks_out[1] = hh_max(pk[2], pk2[2]);
        ex = -ex;
        ev = -ev;
        used += 2;
        amplitude_and_phase(xa, xb, n, sin_tab, cos_tab, a_out, ph);
        dx = ex - x;
        dv = (ev - v) / w;
        d = sqrt(dx * dx + dv * dv) / hh_max(*a_out, 1e-300);
        lam = d / d_prev;
        err = lam >= 1.0 ? INFINITY : d * hh_max(1.0, lam / (1.0 - lam));
        if (err <= tol)
            break;
        d_prev = d;
        x = ex;
        v = ev;
    }
    *used_out = used;
    *resid_out = err;
}

void hh_steady_sine_response(const double *p, double amplitude, double freq, int64_t max_half_periods,
                             double *work, double *a_out, double *phase, int64_t *half_periods, double *residual,
                             int64_t *limits, double *peaks)
{
    steady_sine_response(p, amplitude, freq, steps_per_period(freq), STEADY_TOL, max_half_periods, work, a_out,
                         phase, half_periods, residual, limits, peaks);
}

void hh_spool_bode_point(const double *p, double amplitude, double freq, int max_periods, double *work,
                         double *gain_db, double *phase_deg, int64_t *half_periods, double *residual,
                         int64_t *limits, double *peaks)
{
    double a_out, ph;
    steady_sine_response(p, amplitude, freq, steps_per_period(freq), STEADY_TOL, 2 * (int64_t)max_periods, work,
                         &a_out, &ph, half_periods, residual, limits, peaks);
    *gain_db = 20.0 * log10(hh_max(a_out, 1e-12) / amplitude);
    *phase_deg = ph * 180.0 / HH_PI;
}

void hh_spool_bode(const double *p, int64_t n, const double *amplitude, const double *freq, int max_periods,
                   double *work, double *gain_db, double *phase_deg, int64_t *half_periods, double *residual,
                   int64_t *limits, double *peaks)
{
    int64_t i;
    for (i = 0; i < n; i++)
        hh_spool_bode_point(p, amplitude[i], freq[i], max_periods, work, gain_db + i, phase_deg + i,
                            half_periods + i, residual + i, limits + i, peaks + 2 * i);
}
