/* paper_model.h: the paper's rig in an exported plant (the standalone C plant's rt_rig.c, the FMU's plant_fmu.c)
 * stepping the model generated from its circuit behind the core's loop and rig (loop.c's HH_MODEL_GENERATED), as
 * the Python binding's plants do (simulation/generated_model.py): the circuit's generated C (circuit.c, compiled
 * beside hh_core.c with HH_CORE_LINKED) and the tables of its core adapter (paper_tables.h, written by the export:
 * export/paper_model.py; the same tables the binding fills its adapter from). */
#ifndef PAPER_MODEL_H
#define PAPER_MODEL_H
#include <stddef.h>
#include "hh.h"
#include "hc_core.h"
#include "paper_tables.h"

typedef struct {
    double P[PM_NP], yc[PM_NSTATE], u[PM_NU];   /* the circuit's values, state and inputs */
    int64_t mc[PM_NM];                          /* its modes */
    hc_core_ctx ctx;                            /* pointing into the above: a paper_model is not copied */
} paper_model;

/* 0 when the core's parameters p ask for the export's structure (the cylinder's bulk modulus law), else -1 with
 * the reason in why (size bytes), naming the key. */
int paper_model_structure_check(const double *p, char *why, size_t size);
/* Make sim (hh_sim_init'ed: its parameters, step and delay line) step the generated model with the tableau
 * `method` (hh.h's HH_EULER ...), its context pm; again after sim was restored from an FMU state. Returns 0, or
 * -1 with paper_model_structure_check's reason. */
int paper_model_attach(paper_model *pm, hh_sim *sim, int method, char *why, size_t size);

#endif
