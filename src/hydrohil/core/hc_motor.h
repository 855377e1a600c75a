/* hc_motor.h: one component's law of the library (components.h, SPEC §12.3). */
#ifndef HC_MOTOR_H
#define HC_MOTOR_H
#include "core.h"

/* ---- hydraulic motor, displacement D [m^3/rev]: q = D*w/(2 pi) + Cl*dp; torque eta_hm*D*dp/(2 pi) -------- */
HH_INLINE double hc_motor_flow(double d, double w, double cl, double dp) { return d * w / (2.0 * HC_PI) + cl * dp; }
HH_INLINE double hc_motor_torque(double d, double eta, double dp) { return eta * d * dp / (2.0 * HC_PI); }

#endif
