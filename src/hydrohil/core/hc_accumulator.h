/* hc_accumulator.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_ACCUMULATOR_H
#define HC_ACCUMULATOR_H
#include "core.h"

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

#endif
