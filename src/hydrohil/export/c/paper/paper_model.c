/* paper_model.c: the paper's rig's generated model behind the core's loop in an exported plant (paper_model.h). */
#include <stdio.h>
#include <string.h>
#define PAPER_TABLES
#include "paper_model.h"

int paper_model_structure_check(const double *p, char *why, size_t size)
{
    int constant = p[HH_CYLINDER_BULK_MODULUS] > 0.5;
    if (constant == PM_BULK_CONSTANT)
        return 0;
    snprintf(why, size, "cylinder.bulk_modulus = %s: this plant was exported with \"%s\" (its generated model has "
             "that structure); export it again with the other one (hydrohil export ... --set "
             "cylinder.bulk_modulus=%s, or in the parameter file)", constant ? "constant" : "pressure",
             PM_BULK_CONSTANT ? "constant" : "pressure", constant ? "constant" : "pressure");
    return -1;
}

int paper_model_attach(paper_model *pm, hh_sim *sim, int method, char *why, size_t size)
{
    hc_core_ctx *c = &pm->ctx;
    if (paper_model_structure_check(sim->p, why, size) != 0)
        return -1;
    memcpy(pm->P, PM_P0, sizeof pm->P);      /* (its state's size: hc_state_size(P, h) = PM_NSTATE, no delay line) */
    memset(pm->yc, 0, sizeof pm->yc);
    memset(pm->u, 0, sizeof pm->u);
    memset(pm->mc, 0, sizeof pm->mc);
    c->P = pm->P;
    c->at = PM_AT;
    c->n = PM_N;
    c->command = PM_COMMAND;
    c->method = method;
    c->yc = pm->yc;
    c->u = pm->u;
    c->mc = pm->mc;
    c->cyl_mode = PM_CYL_MODE;
    c->valve_mode = PM_VALVE_MODE;
    c->nfriction = PM_NFRICTION;
    c->friction_column = PM_FRICTION_COLUMN;
    c->cyl_of = PM_CYL_OF;
    c->travel_of = PM_TRAVEL_OF;
    c->friction_of = PM_FRICTION_OF;
    c->pmap = PM_PMAP;
    c->npmap = PM_NPMAP;
    c->wmap = PM_WMAP;
    c->wc = PM_WC;
    c->nwmap = PM_NWMAP;
    hc_init(pm->P, pm->u, sim->h, pm->yc, pm->mc);
    sim->model = HH_MODEL_GENERATED;
    sim->model_step = hc_core_hybrid_step;
    sim->model_friction = hc_core_friction;
    sim->ctx = c;
    return 0;
}
