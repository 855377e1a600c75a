/* params.c: the parameter vector's model slots and its checks (layout: hh_params.h, generated from the
 * pydantic schema, the one place each parameter, its unit and its range are defined). */
#include <stdio.h>
#include "core.h"
#define HH_PARAMS_TABLE
#include "hh_params.h"

void hh_params_derive(double *p)
{
    int i, asym = p[HH_FRICTION_ASYMMETRIC] > 0.5;
    const double *pos = p + (asym ? HH_FRICTION_POSITIVE_FC : HH_FRICTION_SYMMETRIC_FC);
    const double *neg = p + (asym ? HH_FRICTION_NEGATIVE_FC : HH_FRICTION_SYMMETRIC_FC);
    for (i = HH_NP_SCHEMA; i < HH_NP; i++)      /* model constants; fault slots 0 */
        if (!isnan(HH_PARAM_INFO[i].lo))
            p[i] = HH_PARAM_INFO[i].lo;
    for (i = 0; i < 4; i++) {                   /* fc, fs, vs, kv of each direction (SPEC §5) */
        p[HH_FC_POS + i] = pos[i];
        p[HH_FC_NEG + i] = neg[i];
    }
}

const char *hh_param_name(int index) { return index >= 0 && index < HH_NP ? HH_PARAM_INFO[index].key : 0; }
const char *hh_param_unit(int index) { return index >= 0 && index < HH_NP ? HH_PARAM_INFO[index].unit : 0; }

static int bad(char *msg, size_t size, int index, double value, const char *text)
{
    if (size)
        snprintf(msg, size, "parameter %s = %.17g [%s]: %s", HH_PARAM_INFO[index].key, value,
                 HH_PARAM_INFO[index].unit, text);
    return index;
}

int hh_params_check(const double *p, char *msg, size_t msg_size)
{
    static const int sets[3] = {HH_FRICTION_SYMMETRIC_FC, HH_FRICTION_POSITIVE_FC, HH_FRICTION_NEGATIVE_FC};
    char t[160];
    int i;
    if (msg_size)
        msg[0] = 0;
    for (i = 0; i < HH_NP_SCHEMA; i++) {
        const hh_param_info *s = &HH_PARAM_INFO[i];
        double v = p[i];
        if (!isfinite(v))
            return bad(msg, msg_size, i, v, "must be a finite number");
        if (s->kind != HH_KIND_REAL && v != floor(v)) {
            snprintf(t, sizeof t, "must be a whole number in [%g, %g]", s->lo, s->hi);
            return bad(msg, msg_size, i, v, t);
        }
        if (s->lo_strict ? !(v > s->lo) : !(v >= s->lo)) {
            snprintf(t, sizeof t, "must be %s %g", s->lo_strict ? ">" : ">=", s->lo);
            return bad(msg, msg_size, i, v, t);
        }
        if (s->hi_strict ? !(v < s->hi) : !(v <= s->hi)) {
            snprintf(t, sizeof t, "must be %s %g", s->hi_strict ? "<" : "<=", s->hi);
            return bad(msg, msg_size, i, v, t);
        }
    }
    if (!(p[HH_SUPPLY_PS] > p[HH_SUPPLY_PT])) {
        snprintf(t, sizeof t, "must exceed supply.pt (%g Pa)", p[HH_SUPPLY_PT]);
        return bad(msg, msg_size, HH_SUPPLY_PS, p[HH_SUPPLY_PS], t);
    }
    if (!(p[HH_CYLINDER_A2] < p[HH_CYLINDER_A1])) {     /* (the schema's Cylinder._annulus) */
        snprintf(t, sizeof t, "the rod-side annulus must be smaller than cylinder.a1 (%g m^2)", p[HH_CYLINDER_A1]);
        return bad(msg, msg_size, HH_CYLINDER_A2, p[HH_CYLINDER_A2], t);
    }
    for (i = 0; i < 3; i++)
        if (p[sets[i] + 1] < p[sets[i]]) {
            snprintf(t, sizeof t, "the breakaway force must be >= the Coulomb force fc (%g N)", p[sets[i]]);
            return bad(msg, msg_size, sets[i] + 1, p[sets[i] + 1], t);
        }
    if (p[HH_LINEAR_XP0] > p[HH_CYLINDER_STROKE]) {
        snprintf(t, sizeof t, "lies beyond cylinder.stroke (%g m)", p[HH_CYLINDER_STROKE]);
        return bad(msg, msg_size, HH_LINEAR_XP0, p[HH_LINEAR_XP0], t);
    }
    return -1;
}
