/* components.h: the hydraulic component library's laws (SPEC §12.3), SI units, gauge pressures [Pa].
 *
 * Each component is a few inline functions over its parameters and its ports' values, returning flows
 * [m^3/s] (positive from its port a to its port b, or out of a source), capacitances [m^3/Pa] and the guards
 * of its modes. A generated circuit (hydrohil.circuits) calls them in a fixed order inside its right-hand
 * side, so the compiler sees the whole model. Their declarations (ports, parameters with unit, range and
 * description, states, modes) are in hydrohil/circuits/library.py. */
#ifndef HH_COMPONENTS_H
#define HH_COMPONENTS_H
#include "core.h"

#define HC_PI 3.14159265358979323846

/* ---- square-root law with the laminar transition of §3.2: q = k*sign(dp)*sqrt|dp| for |dp| >= dp_t; below,
 * the odd cubic k*sqrt(dp_t)*r*(5 - r^2)/4, r = dp/dp_t (same value and slope at dp_t). k [m^3/s/sqrt(Pa)]. */
HH_INLINE double hc_sqrt_law(double k, double dp, double dp_t)
{
    double r;
    if (dp >= dp_t)
        return k * sqrt(dp);
    if (dp <= -dp_t)
        return -k * sqrt(-dp);
    r = dp / dp_t;
    return k * sqrt(dp_t) * r * (1.25 - 0.25 * r * r);
}

/* ---- orifice: q = Cd*A*sqrt(2|dp|/rho)*sign(dp), dp = pa - pb ---------------------------------------- */
HH_INLINE double hc_orifice_k(double cd, double area, double rho) { return cd * area * sqrt(2.0 / rho); }

/* ---- fixed-displacement pump: q = D*n - Cl*(p_out - p_in); D [m^3/rev], n [rev/s], Cl [m^3/(s.Pa)] ---------
 * Catalogue form: volumetric efficiency eta_v at rated speed n_r and pressure p_r: Cl = (1 - eta_v)*D*n_r/p_r. */
HH_INLINE double hc_pump_flow(double d, double n, double cl, double p_in, double p_out)
{
    return d * n - cl * (p_out - p_in);
}

HH_INLINE double hc_pump_leakage(double d, double eta_v, double n_r, double p_r) { return (1.0 - eta_v) * d * n_r / p_r; }

/* ---- direct-operated relief valve, cracking at p_cr, Q_r at p_r > p_cr: K = Q_r/(p_r - p_cr) -------------
 * Modes: closed (q = 0) while dp <= p_cr; open: q = K*(dp - p_cr). The guard dp = p_cr switches both ways.
 * The check valve is the same law (cracking dp_cr, one direction only). */
enum { HC_CLOSED, HC_OPEN };
HH_INLINE double hc_relief_flow(int mode, double k, double p_cr, double dp) { return mode == HC_OPEN ? k * (dp - p_cr) : 0.0; }

HH_INLINE int hc_relief_mode(int mode, double p_cr, double dp)
{
    (void)mode;
    return dp > p_cr ? HC_OPEN : HC_CLOSED;
}

/* ---- gas-charged accumulator: nominal gas volume V0, precharge p0 (gauge), polytropic exponent n ----------
 * Absolute pressures: for p > p0, V_gas = V0*((p0+pa)/(p+pa))^(1/n), V_oil = V0 - V_gas. Modes: empty (p <= p0:
 * no oil), working, full (V_gas at its minimum v_min: a rigid volume). */
enum { HC_ACC_EMPTY, HC_ACC_WORKING, HC_ACC_FULL };

HH_INLINE double hc_acc_gas_volume(double v0, double p0, double n, double p)
{
    return p <= p0 ? v0 : v0 * pow((p0 + HH_P_ATM) / (p + HH_P_ATM), 1.0 / n);
}

HH_INLINE double hc_acc_oil_volume(double v0, double p0, double n, double p) { return v0 - hc_acc_gas_volume(v0, p0, n, p); }

/* dV_oil/dp [m^3/Pa] in the working mode: V0*(p0+pa)^(1/n) / (n*(p+pa)^(1+1/n)); 0 empty or full. */
HH_INLINE double hc_acc_capacitance(int mode, double v0, double p0, double n, double p)
{
    if (mode != HC_ACC_WORKING)
        return 0.0;
    return v0 * pow(p0 + HH_P_ATM, 1.0 / n) / (n * pow(p + HH_P_ATM, 1.0 + 1.0 / n));
}

/* The mode at pressure p: empty at or below the precharge, full once the gas is at v_min. */
HH_INLINE int hc_acc_mode(double v0, double p0, double n, double v_min, double p)
{
    if (p <= p0)
        return HC_ACC_EMPTY;
    return hc_acc_gas_volume(v0, p0, n, p) <= v_min ? HC_ACC_FULL : HC_ACC_WORKING;
}

/* ---- hose / line of inner diameter d, length L: volume pi*d^2*L/4; friction factor the larger of laminar
 * 64/Re and Blasius' turbulent 0.3164*Re^-0.25 (SPEC §12.3: laminar R = 128*mu*L/(pi*d^4), turbulent at high
 * Re): continuous in dp, the two meet at Re = 1190 (below the usual 2300, where Blasius gives more friction
 * than the laminar law: the transition band is modelled by the larger). mu = rho*nu; flow a -> b, dp = pa - pb. */
HH_INLINE double hc_hose_volume(double d, double len) { return 0.25 * HC_PI * d * d * len; }

HH_INLINE double hc_hose_resistance(double d, double len, double rho, double nu)
{
    return 128.0 * rho * nu * len / (HC_PI * d * d * d * d);
}

HH_INLINE double hc_hose_flow(double d, double len, double rho, double nu, double dp)
{
    double area = 0.25 * HC_PI * d * d, a = fabs(dp), q_lam = a / hc_hose_resistance(d, len, rho, nu), q_turb;
    /* Blasius: dp = 0.3164*(v*d/nu)^-0.25*(L/d)*rho*v^2/2  ->  v^1.75 = 2*dp*d^1.25 / (0.3164*L*rho*nu^0.25) */
    q_turb = area * pow(2.0 * a * pow(d, 1.25) / (0.3164 * len * rho * pow(nu, 0.25)), 1.0 / 1.75);
    q_lam = q_lam < q_turb ? q_lam : q_turb;
    return dp < 0.0 ? -q_lam : q_lam;
}

/* ---- a node's pressure: dp/dt = sum(q_in) / C, C = V/beta + the accumulators' capacitances ------------- */
HH_INLINE double hc_node_rate(double q_in, double volume, double beta, double c_extra)
{
    return q_in / (volume / beta + c_extra);
}

#endif
