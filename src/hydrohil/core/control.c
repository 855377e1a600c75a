/* control.c: built-in controllers (see control.h for the law). */
#include "control.h"

/* The paper's P law, u = clamp(kp*(x_ref - x), -1, 1): the 'hold' safe state of the watchdog. */
HH_INLINE double p_control(double kp, double x_ref, double x_meas)
{
    double u = kp * (x_ref - x_meas);
    return hh_min(hh_max(u, -1.0), 1.0);
}

/* The P law's command of hh_controller_update (HH_CTRL_P): inline where a loop calls it each step (the generated
 * hc_run), the one source of the law's arithmetic */
HH_INLINE double hh_p_law(const hh_controller *c, double x_ref, double x)
{
    return hh_clamp(c->kp * (x_ref - x), c->u_min, c->u_max);
}

#ifndef HH_CORE_LINKED   /* (hh.h's functions of this part; a translation unit linked with hh_core.c, which defines
                           them, leaves them out: core.h) */
void hh_controller_reset(hh_controller_state *s)
{
    s->integral = 0.0;
    s->velocity = 0.0;
    s->x_prev = 0.0;
    s->pl_prev = 0.0;
    s->pl_filtered = 0.0;
    s->started = 0;
}

double hh_controller_update(const hh_controller *c, hh_controller_state *s, double x_ref, double dx_ref, double x,
                            double p1, double p2)
{
    double e = x_ref - x, pl = p1 - c->area_ratio * p2, u_star, u;
    if (c->type == HH_CTRL_P)   /* the paper's law: no filter, no state (the hot path of most runs) */
        return hh_p_law(c, x_ref, x);
    if (!s->started) {          /* the first sample: the filters start at rest on the first measurement */
        s->x_prev = x;
        s->pl_prev = pl;
        s->started = 1;
    }
    s->velocity = (c->tf * s->velocity + (x - s->x_prev)) / (c->tf + c->h);
    s->pl_filtered = c->tpl > 0.0 ? c->tpl / (c->tpl + c->h) * (s->pl_filtered + pl - s->pl_prev) : pl;
    s->x_prev = x;
    s->pl_prev = pl;
    u_star = c->kp * e + (s->integral + c->kff * dx_ref + c->u_bias - c->kd * s->velocity - c->kpl * s->pl_filtered);
    if (c->u_deadband != 0.0)
        u_star += c->u_deadband * hh_clamp(e / c->e_deadband, -1.0, 1.0);
    u = hh_clamp(u_star, c->u_min, c->u_max);
    if (c->ki != 0.0) {
        if (c->antiwindup == HH_AW_BACK_CALCULATION)
            s->integral += c->ki * c->h * e + c->h / hh_max(c->tt, c->h) * (u - u_star);
        else if (u == u_star || (u_star > u) != (e > 0.0))     /* clamp: never integrate further into a limit */
            s->integral += c->ki * c->h * e;
    }
    return u;
}
#endif
