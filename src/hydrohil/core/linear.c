/* linear.c: the plant linearised at an operating point at rest (README "Linear analysis"; the paper's
 * eq 18-20 generalised). Exact derivatives of the hybrid model's equations in its free-sliding mode:
 *
 *   state  [xs, vs, p1, p2, vp, xp]      inputs [ū (after the valve's pure delay), F_L]
 *   dxs = vs                             dvs = wn^2*(ū - xs) - 2*xi*wn*vs            (SPEC §3.1, linear)
 *   dp1 = beta1/V1*(Q1(xs, p1) - A1*vp - g*(p1 - p2))                                 (SPEC §4, eq 21-22)
 *   dp2 = beta2/V2*(Q2(xs, p2) + A2*vp + g*(p1 - p2))
 *   dvp = (A1*p1 - A2*p2 - F_L + dir*M*g_n - Ff(vp))/M                              (eq 28)
 *   dxp = vp
 *
 * At the operating point the net flows are zero (the piston at rest), so the derivatives of beta(p) and of
 * V(xp) multiply zero and drop out; beta_i is eq 21 at the operating pressure. The flow gains
 * Kq_i = dQ_i/dxs are the orifice flows through the pseudo-section slopes of eq 3, the pressure-flow
 * coefficients Kc_i = -dQ_i/dp_i the orifice slopes (SPEC §3.2); friction enters as its local viscous
 * slope dFf/dvp (the caller's choice). Row-major A[6*6], B[6*2]; coefficients: beta1, beta2, V1, V2, Kq1,
 * Kq2, Kc1, Kc2. */
#include "cylinder.h"

void hh_valve_flows(const double *p, double xs, double p1, double p2, double *q1, double *q2)
{
    valve_flows(xs, p1, p2, p, p[HH_VALVE_DP_LAMINAR], q1, q2);
}

void hh_linearise(const double *p, double xs, double p1, double p2, double xp, double friction_slope, double *A,
                  double *B, double *coef)
{
    hh_sections s = pseudo_sections(xs, p), ds = pseudo_section_slopes(xs, p);
    double ps = p[HH_SUPPLY_PS], pt = p[HH_SUPPLY_PT], dl = p[HH_VALVE_DP_LAMINAR];
    double a1 = p[HH_CYLINDER_A1], a2 = p[HH_CYLINDER_A2], g = p[HH_CYLINDER_G_LKC], m = p[HH_LOAD_MASS];
    double wn = p[HH_SPOOL_WN], xi = p[HH_SPOOL_XI], v1, v2, b1, b2, kq1, kq2, kc1, kc2, e1, e2;
    int i;
    for (i = 0; i < 36; i++)
        A[i] = 0.0;
    for (i = 0; i < 12; i++)
        B[i] = 0.0;
    volumes(xp, p, &v1, &v2);
    b1 = bulk_modulus(p1, 1, p);
    b2 = bulk_modulus(p2, 2, p);
    kq1 = orifice_flow(ds.as1, ps - p1, dl) - orifice_flow(ds.a1t, p1 - pt, dl);
    kq2 = orifice_flow(ds.as2, ps - p2, dl) - orifice_flow(ds.a2t, p2 - pt, dl);
    kc1 = orifice_slope(s.as1, ps - p1, dl) + orifice_slope(s.a1t + p[HH_BURST1], p1 - pt, dl);
    kc2 = orifice_slope(s.as2, ps - p2, dl) + orifice_slope(s.a2t + p[HH_BURST2], p2 - pt, dl);
    e1 = b1 / v1;
    e2 = b2 / v2;
    A[0 * 6 + 1] = 1.0;                                    /* dxs = vs */
    A[1 * 6 + 0] = -wn * wn;                               /* dvs */
    A[1 * 6 + 1] = -2.0 * xi * wn;
    B[1 * 2 + 0] = wn * wn;
    A[2 * 6 + 0] = e1 * kq1;                               /* dp1 */
    A[2 * 6 + 2] = -e1 * (kc1 + g);
    A[2 * 6 + 3] = e1 * g;
    A[2 * 6 + 4] = -e1 * a1;
    A[3 * 6 + 0] = e2 * kq2;                               /* dp2 */
    A[3 * 6 + 2] = e2 * g;
    A[3 * 6 + 3] = -e2 * (kc2 + g);
    A[3 * 6 + 4] = e2 * a2;
    A[4 * 6 + 2] = a1 / m;                                 /* dvp */
    A[4 * 6 + 3] = -a2 / m;
    A[4 * 6 + 4] = -friction_slope / m;
    B[4 * 2 + 1] = -1.0 / m;
    A[5 * 6 + 4] = 1.0;                                    /* dxp = vp */
    coef[0] = b1;
    coef[1] = b2;
    coef[2] = v1;
    coef[3] = v2;
    coef[4] = kq1;
    coef[5] = kq2;
    coef[6] = kc1;
    coef[7] = kc2;
}
