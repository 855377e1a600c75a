/* control.h: the built-in position controllers of the sampled loop (README "Controllers").
 *
 * One sampled law with sample time h covers every built-in type; a type is the set of gains it may use
 * (scenario [controller], hydrohil/control.py validates which):
 *
 *   e  = x_ref - x                                          position error [m] (x: the encoder reading)
 *   v  = (tf*v_prev + x - x_prev) / (tf + h)                velocity estimate [m/s]: d/dt through 1/(tf*s + 1)
 *   pL = p1 - (A2/A1)*p2                                    load pressure [Pa] from the transducers
 *   pf = tpl > 0 ? tpl/(tpl + h)*(pf_prev + pL - pL_prev)   high-passed load pressure (dynamic pressure
 *               : pL                                        feedback: no steady-state error from a load)
 *   u* = kp*e + I + kff*dx_ref + u_bias + u_db*clamp(e/e_db, -1, 1) - kd*v - kpl*pf
 *   u  = clamp(u*, u_min, u_max)                            the normalised valve command ū
 *   I += ki*h*e                                  (anti-windup 'clamp': not while u* is beyond a limit the
 *                                                 error pushes towards)
 *   I += ki*h*e + (h/tt)*(u - u*)                (anti-windup 'back_calculation', tracking time tt [s];
 *                                                 a tt below h acts as h: the correction never overshoots)
 *
 * Units: kp ū/m, ki ū/(m·s), kd ū/(m/s), kff ū/(m/s), kpl ū/Pa, e_db m, tf/tt/tpl s. P: kp only (the
 * paper's §4 law, u = clamp(kp*e, -1, 1)); PI: + ki; PID: + kd, tf (derivative on the measurement, no kick
 * at reference steps); p_ff: + kff, u_bias, u_db, e_db; state_feedback: kp, kd, tf, kpl, tpl (+ ki). */
#ifndef HH_CONTROL_H
#define HH_CONTROL_H
#include "core.h"

HH_INLINE double p_control(double kp, double x_ref, double x_meas);

#endif
