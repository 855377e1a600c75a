/* hh_core.c: the whole core as one translation unit (see core.h), and the public wrappers of hh.h.
 * Build: cc -std=c99 -O2 -ffp-contract=off -c hh_core.c (hh_params.h generated beside it). */
#include "valve.c"
#include "friction.c"
#include "cylinder.c"
#include "rk.c"
#include "hybrid.c"
#include "reference.c"
#include "rest.c"
#include "sensors.c"
#include "rng.c"
#include "control.c"
#include "watchdog.c"
#include "link.c"
#include "delay.c"
#include "loop.c"
#include "rig.c"
#include "params.c"
#include "spool_bode.c"
#include "linear.c"

double hh_orifice_flow(double area, double dp, double dp_t) { return orifice_flow(area, dp, dp_t); }
double hh_real_axis_limit(int method) { return HH_TABLEAUS[method].real_axis_limit; }
double hh_orifice_slope(double area, double dp, double dp_t) { return orifice_slope(area, dp, dp_t); }

int hh_spool_derivatives(double xs, double vs, double ud, const double *p, double *dxs, double *dvs)
{
    return spool_derivatives(xs, vs, ud, p, dxs, dvs);
}

void hh_reference_rhs(const double *y, double ud, const double *p, double *dy)
{
    reference_rhs(y, ud, 0, p, 0, dy);
}

double hh_lugre_force(double v, double z, const double *p)
{
    double dz;
    return lugre(v, z, p, &dz);
}

double hh_external_force(double p1, double p2, const double *p) { return external_force(p1, p2, p); }
double hh_friction_force(const double *y, const int64_t *m, const double *p) { return friction_force(y, m, p); }

int hh_hybrid_step(int method, double *y, int64_t *m, const double *p, double ud, double h)
{
    return hybrid_step(method, y, m, p, ud, h);
}

double hh_encoder_counts(double xp, double resolution) { return encoder_counts(xp, resolution); }
double hh_count_size(double resolution) { return count_size(resolution); }
double hh_p_control(double kp, double x_ref, double x_meas) { return p_control(kp, x_ref, x_meas); }
