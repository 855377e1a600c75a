/* plant_fmu.h: one instance of an exported circuit (`hydrohil export fmu --circuit`), independent of the FMI
 * version: the circuit's generated C (circuit.c: hc_init, hc_step, hc_row, hc_rest) stepped on its own grid,
 * its signals as the FMU's inputs and outputs. The same functions as the paper's rig's instance layer
 * (export/c/fmu/plant_fmu.h), so fmi2Functions.c, fmi3Functions.c and fmu_instance.c serve both. Sizes,
 * value references and start values: config.h (generated with the circuit). */
#ifndef PLANT_FMU_H
#define PLANT_FMU_H

#include "fmu_instance.h"
#include "config.h"

/* the instance's values besides those the shared layer reads (mode, prepared, t0, t_comm): an FMU state
 * copies them whole */
typedef struct {
    double P[CIRCUIT_NP];           /* the circuit's parameters (fixed at export) */
    double u[CIRCUIT_NU];           /* inputs as set, held over each internal step */
    double y[CIRCUIT_NY];           /* state: node pressures, then the components' states */
    int64_t m[CIRCUIT_NM];          /* modes */
    double row[CIRCUIT_NLOG];       /* the outputs of the last grid point under the inputs as set now */
    int64_t row_valid;              /* row is of the current state and inputs */
    int64_t k;                      /* internal steps taken */
    int64_t inputs_set;             /* an input was set before initialisation: the rest is found again */
} circuit_values;

struct plant {
    circuit_values v;
    double t0, t_comm;
    int mode;
    int prepared;
    int me, me_event;               /* Model Exchange: this instance's interface; in event mode (fmu_instance.h) */
    double t_me;                    /* Model Exchange: the time the importer set */
    fmu_delay me_in[CIRCUIT_NDELAY];    /* Model Exchange: each delayed input as its component sees it */
    int64_t me_idx[CIRCUIT_NDELAY];     /* ... the input it delays */
    int64_t me_nd;
    char name[80];
    plant_log_fn log;
    void *env;
};

/* the generated circuit (circuit.c) */
void hc_init(const double *P, const double *u, double h, double *y, int64_t *m);
int hc_step(const double *P, double *y, int64_t *m, const double *u, int method, double h);
void hc_row(const double *P, const double *y, const int64_t *m, const double *u, double t, double *row);
int64_t hc_unphysical(const double *P, const double *y);
void hc_state_bounds(const double *P, double *lo, double *hi);
int64_t hc_rest(const double *P, const double *u, double *y, int64_t *m, const int64_t *held, int method, double h,
                int64_t max_steps, double rel_tol);
/* its Model Exchange (circuits/generate.py; hc_core.h declares them for every unit that includes it) */
void hc_rhs(const double *P, const double *y, const int64_t *m, const double *u, double *dy);
void hc_me_indicators(const double *P, const double *y, const int64_t *m, const double *u, double *z);
int hc_me_event(const double *P, double *y, int64_t *m, const double *u);
int hc_me_step_event(const double *P, const double *y, const int64_t *m, const double *u);
int64_t hc_me_delays(const double *P, int64_t *idx, double *tau);

#endif
