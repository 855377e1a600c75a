/* cylinder.c: differential cylinder, SPEC §4 (see cylinder.h). */
#include "cylinder.h"

/* Effective bulk modulus [Pa] at gauge `pressure` [Pa]: eq 21 (1e5 + P)/(B*P + C), or the constant
 * value of the chamber (1 or 2) when cylinder.bulk_modulus = "constant". */
HH_INLINE double bulk_modulus(double pressure, int chamber, const double *p)
{
    if (p[HH_CYLINDER_BULK_MODULUS] > 0.5)
        return chamber == 1 ? p[HH_CYLINDER_BETA1] : p[HH_CYLINDER_BETA2];
    return hc_bulk_modulus(pressure, p[HH_CYLINDER_B], p[HH_CYLINDER_C]);
}

/* Chamber volumes [m^3]: V1 = V01 + A1*xp, V2 = V02 + A2*(L - xp), xp limited to the stroke. */
HH_INLINE void volumes(double xp, const double *p, double *v1, double *v2)
{
    double x = hh_min(hh_max(xp, 0.0), p[HH_CYLINDER_STROKE]);
    *v1 = p[HH_CYLINDER_V01] + p[HH_CYLINDER_A1] * x;
    *v2 = p[HH_CYLINDER_V02] + p[HH_CYLINDER_A2] * (p[HH_CYLINDER_STROKE] - x);
}

/* (dP1/dt, dP2/dt) [Pa/s] by continuity (SPEC §4) with the valve flows of SPEC §3.2:
 * Q1 = q_s1 - q_1t, Q2 = q_s2 - q_2t, q_lkc = g_lkc*(P1 - P2) (eq 22),
 * dP1/dt = c1*beta(P1)/V1*(Q1 - A1*vp - q_lkc), dP2/dt = c2*beta(P2)/V2*(Q2 + A2*vp + q_lkc).
 * dp_t: laminar transition of the orifices; c1, c2: capacitance scales (1 = physical; the hybrid model's
 * stiff-chamber slowing, hybrid.c). A burst hose (fault) drains chamber i through p[HH_BURSTi]. */
/* Net valve flows into the chambers [m^3/s] (SPEC §3.2): q1 = q_s1 - q_1t, q2 = q_s2 - q_2t (a burst hose
 * drains through its chamber's tank side). */
HH_INLINE void valve_flows(double xs, double p1, double p2, const double *p, double dp_t, double *q1, double *q2)
{
    hh_sections s = pseudo_sections(xs, p);
    double ps = p[HH_SUPPLY_PS], pt = p[HH_SUPPLY_PT];
    *q1 = orifice_flow(s.as1, ps - p1, dp_t) - orifice_flow(s.a1t + p[HH_BURST1], p1 - pt, dp_t);
    *q2 = orifice_flow(s.as2, ps - p2, dp_t) - orifice_flow(s.a2t + p[HH_BURST2], p2 - pt, dp_t);
}

HH_INLINE void chamber_pressure_rates(double xs, double p1, double p2, double xp, double vp, const double *p,
                                   double dp_t, double c1, double c2, double *dp1, double *dp2)
{
    double v1, v2, q1, q2, q_lk;
    valve_flows(xs, p1, p2, p, dp_t, &q1, &q2);
    q_lk = p[HH_CYLINDER_G_LKC] * (p1 - p2);
    volumes(xp, p, &v1, &v2);
    *dp1 = c1 * bulk_modulus(p1, 1, p) / v1 * (q1 - p[HH_CYLINDER_A1] * vp - q_lk);
    *dp2 = c2 * bulk_modulus(p2, 2, p) / v2 * (q2 + p[HH_CYLINDER_A2] * vp + q_lk);
}

/* Drive terms of the quasi-static chamber pressures (the hybrid model's stiff chambers, hybrid.c).
 * Pq_i balances chamber i's net inflow F_i against the displacement flow: F1(Pq1) = A1*vp,
 * F2(Pq2) = -A2*vp; with g_i = -dF_i/dP_i, dPq1/dt = (dF1/dxs*dxs/dt - A1*dvp/dt)/g1 and
 * dPq2/dt = (dF2/dxs*dxs/dt + A2*dvp/dt)/g2. Returns the numerators [m^3/s^2]; the flows are linear in
 * the pseudo-sections, so dF/dxs is the orifice flow through the section slopes. */
HH_INLINE void quasi_static_drift(double xs, double dxs, double p1, double p2, double dvp, const double *p,
                               double dp_t, double *d1, double *d2)
{
    hh_sections ds = pseudo_section_slopes(xs, p);
    double ps = p[HH_SUPPLY_PS], pt = p[HH_SUPPLY_PT];
    double dq1 = orifice_flow(ds.as1, ps - p1, dp_t) - orifice_flow(ds.a1t, p1 - pt, dp_t);
    double dq2 = orifice_flow(ds.as2, ps - p2, dp_t) - orifice_flow(ds.a2t, p2 - pt, dp_t);
    *d1 = dq1 * dxs - p[HH_CYLINDER_A1] * dvp;
    *d2 = dq2 * dxs + p[HH_CYLINDER_A2] * dvp;
}

/* Hydraulic + gravity + load force on the piston along +x [N] (eq 28 without friction). */
HH_INLINE double external_force(double p1, double p2, const double *p)
{
    return p1 * p[HH_CYLINDER_A1] - p2 * p[HH_CYLINDER_A2] - p[HH_LOAD_FORCE]
           + p[HH_LOAD_GRAVITY_DIRECTION] * p[HH_LOAD_MASS] * p[HH_LOAD_GRAVITY];
}
