/* control.c: built-in controllers (see control.h). */
#include "control.h"

HH_INLINE double p_control(double kp, double x_ref, double x_meas)
{
    double u = kp * (x_ref - x_meas);
    return hh_min(hh_max(u, -1.0), 1.0);
}
