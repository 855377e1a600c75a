/* hc_pump.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_PUMP_H
#define HC_PUMP_H
#include "core.h"

/* ---- fixed-displacement pump: q = D*n - Cl*(p_out - p_in); D [m^3/rev], n [rev/s], Cl [m^3/(s.Pa)] ---------
 * Catalogue form: volumetric efficiency eta_v at rated speed n_r and pressure p_r: Cl = (1 - eta_v)*D*n_r/p_r. */
HH_INLINE double hc_pump_flow(double d, double n, double cl, double p_in, double p_out)
{
    return d * n - cl * (p_out - p_in);
}

HH_INLINE double hc_pump_leakage(double d, double eta_v, double n_r, double p_r) { return (1.0 - eta_v) * d * n_r / p_r; }

#endif
