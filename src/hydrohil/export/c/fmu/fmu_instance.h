/* fmu_instance.h: the instance interface every exported plant gives the FMI layer (fmi2Functions.c,
 * fmi3Functions.c): status codes, the life cycle's modes, the functions, Co-Simulation's and Model Exchange's.
 * Each model's plant_fmu.h defines its `struct plant` (with at least the fields mode, prepared, t0, t_comm, name,
 * log, env and Model Exchange's me, me_event, t_me) and includes this; fmu_instance.c has what they share. */
#ifndef FMU_INSTANCE_H
#define FMU_INSTANCE_H

#include <stddef.h>
#include <stdint.h>
#include "hh_compat.h"           /* (the core's: no fused multiply-add; old glibc symbols in the exports' binaries) */

enum { PLANT_OK = 0, PLANT_WARNING = 1, PLANT_ERROR = 3 };
enum { PLANT_INSTANTIATED, PLANT_INITIALIZING, PLANT_STEPPING, PLANT_TERMINATED, PLANT_FAILED };

/* status: PLANT_OK / PLANT_WARNING / PLANT_ERROR; category: "logStatusError", ... */
typedef void (*plant_log_fn)(void *env, const char *instance, int status, const char *category, const char *msg);
typedef struct plant plant;

plant *plant_new(const char *name, plant_log_fn log, void *env);
void plant_free(plant *pl);
void plant_defaults(plant *pl);                 /* start values of every variable, state INSTANTIATED */
int plant_set_real(plant *pl, unsigned vr, double v);
int plant_get_real(plant *pl, unsigned vr, double *v);
int plant_get_integer(plant *pl, unsigned vr, int *v);   /* an Integer's or an Enumeration's */
int plant_set_integer(plant *pl, unsigned vr, int v);
int plant_get_boolean(plant *pl, unsigned vr, int *v);
int plant_set_boolean(plant *pl, unsigned vr, int v);
int plant_setup(plant *pl, double t0);          /* the start time, before initialisation */
int plant_enter_init(plant *pl, double t0);
int plant_exit_init(plant *pl);                 /* checks the parameters, sets the initial state */
int plant_do_step(plant *pl, double t, double dt);
int plant_terminate(plant *pl);
/* FMU state: the instance's values (no pointers) as one block of bytes: a tag, its format version, the
 * export's token and the sizes first, then the values; serialising is a copy, deserialising checks the tag,
 * version, token and sizes. get: (re)allocates *state; set: restores it; size: of the block. */
int plant_state_get(plant *pl, void **state);
int plant_state_set(plant *pl, const void *state);
size_t plant_state_block_size(const void *state);
int plant_state_serialize(plant *pl, const void *state, void *bytes, size_t size);
int plant_state_deserialize(plant *pl, const void *bytes, size_t size, void **state);
void plant_logf(plant *pl, int status, const char *fmt, ...);

/* An FMU state block's header (each model's values and, for the rig, its delay line follow it): a tag, the
 * format version, the export's token, the model's sizes, the size of its values, its extra doubles, the
 * block's size. */
typedef struct {
    char tag[24];
    uint32_t version, header_size;
    char token[48];
    uint64_t dims[6], values_size, extra, total;
} plant_state_header;

/* ---- Model Exchange: the importer's solver integrates the model (each model's plant_fmu.c) ------------------
 * An ME instance (pl->me) is in event mode (pl->me_event) from the end of initialisation, and after
 * enterEventMode, else in continuous-time mode; pl->t_me is the time the importer set. */
int plant_me_start(plant *pl);                     /* after initialisation: the delayed inputs' histories */
int plant_me_states(plant *pl, double *x, size_t nx, int set);   /* the continuous states: get, or set (set 1) */
int plant_me_nominals(plant *pl, double *x, size_t nx);
int plant_me_derivatives(plant *pl, double *dx, size_t nx);
int plant_me_indicators(plant *pl, double *z, size_t nz);
/* an event's update (the transitions, a delayed input's change): *changed 1 when the states' values changed;
 * *next_defined, *next: the next time event (a delayed input's next change) */
int plant_me_update(plant *pl, int *changed, int *next_defined, double *next);
/* the end of an integrator's step: *enter_event 1 when an event is due there; *terminate when the state left
 * its physical range (said) */
int plant_me_step_done(plant *pl, int *enter_event, int *terminate);

/* the life cycle's checks of Model Exchange's calls (fmu_instance.c): an ME instance initialised, in event mode
 * (event 1), in continuous-time mode (event 0) or either (event -1) */
int plant_me_check(plant *pl, const char *call, int event);
int plant_me_set_time(plant *pl, double t);

/* A delayed input of Model Exchange (a valve's command delay): what the model sees at time t is the input at
 * t - tau, from its history: the values set in event mode (a step: the value jumps there, and reaches the model at
 * a time event tau later, once the importer handled it) and those in force at the end of each of the solver's
 * accepted steps (linear between them: a continuous input); before the start, the value at the start. A value set
 * in continuous-time mode at a trial point is the input's newest (beyond the history). tau 0: at once. */
#define FMU_DELAY_CAP 4096
typedef struct {
    double tau;
    double now, t_now;              /* the value set last, and when */
    int n;                          /* history: (t[i], v[i]), t non-decreasing; two at one time: a step there */
    double t[FMU_DELAY_CAP], v[FMU_DELAY_CAP];
    double t_done;                  /* the steps at or before t_done - tau reached the model (their time event) */
} fmu_delay;
void fmu_delay_init(fmu_delay *d, double tau, double t0, double value);
/* the importer sets value at t (event: in event mode, a step of the input) */
int fmu_delay_set(plant *pl, fmu_delay *d, double t, double value, int event);
int fmu_delay_accept(plant *pl, fmu_delay *d, double t);   /* a solver's step accepted at t: its value kept */
void fmu_delay_event(fmu_delay *d, double t);      /* event mode at t: the steps due by then reach the model */
double fmu_delay_value(const fmu_delay *d, double t);   /* what the model sees at t */
int fmu_delay_next(const fmu_delay *d, double t, double *next);   /* 1 and the next step's arrival after t, or 0 */

/* shared by every exported plant (fmu_instance.c) */
int plant_wrong_mode(plant *pl, const char *call, const char *where);
int plant_step_check(plant *pl, double t, double dt, double h);
/* Model Exchange: an array of n `what` where the FMU has `want` (PLANT_OK, or an error naming both) */
int plant_me_size(plant *pl, size_t n, size_t want, const char *what);
void plant_state_header_of(plant_state_header *hd, const char *tag, uint32_t version, const uint64_t dims[6],
                           uint64_t values_size, uint64_t extra);
/* the header of `bytes` (size bytes) into *hd when it is a block of this FMU's tag, version and token;
 * PLANT_ERROR with a message when not (the model then checks its sizes: plant_state_check) */
int plant_state_header_read(plant *pl, const void *bytes, size_t size, const char *tag, uint32_t version,
                            plant_state_header *hd);
/* the block is exactly the model's (its header equal to `mine`, its size the header's total) */
int plant_state_header_match(plant *pl, const plant_state_header *hd, const plant_state_header *mine, size_t size);
/* given by the model's instance layer (plant_fmu.c) */
int plant_prepare(plant *pl);                    /* the initial state of the values as set */
int plant_state_check(plant *pl, const void *bytes, size_t size);   /* a state block of this FMU? */

#endif
