/* hc_core.h: a circuit in the core's layout — the paper's circuit behind the core's loop and rig (loop.c's
 * HH_MODEL_GENERATED, HH_MODEL_EXTERNAL): the context of the generated hc_core_* functions (circuits/generate.py)
 * and their interface. Every layer that steps the paper's rig fills one: the Python binding
 * (simulation/generated_model.py), the standalone C plant and the FMU (export/c/paper/paper_model.c, from the
 * tables the export writes). circuits/build.py gives the block between the cdef marks to cffi as it is. */
#ifndef HC_CORE_H
#define HC_CORE_H
#include <stdint.h>

/* cdef: begin */
typedef struct {
    double *P;                 /* the circuit's parameter values (the mapped ones set from the loop's at each call) */
    const int64_t *at;         /* the loop's state i is the circuit's state at[i] (n of them) */
    int64_t n;
    int64_t command;           /* the input that takes the loop's spool input */
    int method;                /* the tableau of a step (hh.h: HH_EULER ...) */
    double *yc;                /* the circuit's state (hc_state_size doubles), its inputs, its modes */
    double *u;
    int64_t *mc;
    int64_t cyl_mode, valve_mode, nfriction, friction_column;   /* the modes' places; the log's friction force */
    const int64_t *cyl_of;     /* the cylinder's one mode of the loop's (travel, friction): [travel * nfriction + f] */
    const int64_t *travel_of;  /* the loop's travel and friction modes of the cylinder's */
    const int64_t *friction_of;
    const int64_t *pmap;       /* npmap pairs (the loop's p slot, the circuit's P slot) */
    int64_t npmap;
    const int64_t *wmap;       /* nwmap rows (the circuit's P slot, three of the loop's p slots): their product * wc */
    const double *wc;
    int64_t nwmap;
} hc_core_ctx;
int hc_core_continuous_advance(void *ctx, double t, double h, double alpha, double u_old, double u_new, double *y);
int hc_core_hybrid_step(void *ctx, double *y, int64_t *m, const double *p, double ud, double h);
double hc_core_friction(void *ctx, const double *y, const int64_t *m, const double *p);
/* Model Exchange in the core's layout (the paper's rig's FMU): the derivatives, the event indicators, an event's
 * transitions (1: the state or a mode changed), an event due at a solver step's end */
void hc_core_me_derivatives(void *ctx, const double *y, const int64_t *m, const double *p, double ud, double *dy);
void hc_core_me_indicators(void *ctx, const double *y, const int64_t *m, const double *p, double ud, double *z);
int hc_core_me_event(void *ctx, double *y, int64_t *m, const double *p, double ud);
int hc_core_me_step_event(void *ctx, const double *y, const int64_t *m, const double *p, double ud);
/* cdef: end */

/* the generated circuit's own functions an adapter starts it with (circuits/build.py's CDEF declares them too) */
void hc_init(const double *P, const double *u, double h, double *y, int64_t *m);
int64_t hc_state_size(const double *P, double h);
/* ... and Model Exchange's, in the circuit's own layout (a circuit's FMU): its sizes (states, modes, event
 * indicators, delayed inputs), the derivatives in the modes m under the inputs u as the components see them, the
 * event indicators, an event's transitions, an event due at a step's end, the delayed inputs and their delays */
void hc_me_sizes(int64_t *ny, int64_t *nm, int64_t *nz, int64_t *nd);
void hc_rhs(const double *P, const double *y, const int64_t *m, const double *u, double *dy);
void hc_me_indicators(const double *P, const double *y, const int64_t *m, const double *u, double *z);
int hc_me_event(const double *P, double *y, int64_t *m, const double *u);
int hc_me_step_event(const double *P, const double *y, const int64_t *m, const double *u);
int64_t hc_me_delays(const double *P, int64_t *idx, double *tau);

#endif
