/* hc_hose.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_HOSE_H
#define HC_HOSE_H
#include "core.h"

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

/* d(hc_hose_flow)/d(dp): 1/R where laminar, q/(1.75*|dp|) where turbulent (q ~ |dp|^(1/1.75)) */
HH_INLINE double hc_hose_slope(double d, double len, double rho, double nu, double dp)
{
    double r = hc_hose_resistance(d, len, rho, nu), q = fabs(hc_hose_flow(d, len, rho, nu, dp));
    return q < fabs(dp) / r ? q / (1.75 * fabs(dp)) : 1.0 / r;
}


#endif
