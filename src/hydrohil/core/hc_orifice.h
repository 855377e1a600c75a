/* hc_orifice.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_ORIFICE_H
#define HC_ORIFICE_H
#include "core.h"
#include "hc_sqrt_law.h"

/* ---- orifice: q = Cd*A*sqrt(2|dp|/rho)*sign(dp), dp = pa - pb ---------------------------------------- */
HH_INLINE double hc_orifice_k(double cd, double area, double rho) { return cd * area * sqrt(2.0 / rho); }

#endif
