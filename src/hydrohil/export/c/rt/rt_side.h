/* rt_side.h: the live panel's side channel (rt_side.c) and what the model behind the plant gives it (rt_rig.c:
 * the paper's rig; rt_circuit.c: a circuit): its telemetry columns and rows, the commands a session records, its
 * steering operations. rt_side.c owns the socket, the JSON, the session folder and the recordings. */
#ifndef RT_SIDE_H
#define RT_SIDE_H
#include "rt_plant.h"

/* ---- a JSON object of the panel: flat fields and one nested object (a fault) ---------------------- */
enum { J_STR, J_NUM, J_NULL, J_BOOL, J_OBJ };
#define J_FIELDS 32

typedef struct {
    char key[64];                 /* "op", ...; a nested object's fields "fault.type", ... */
    int kind;
    double num;
    const char *str;              /* J_STR: decoded (in the object's string store) */
    const char *raw;              /* the value as the message wrote it (an object: its text) */
    size_t raw_len;
} jfield;

typedef struct {
    jfield f[J_FIELDS];
    int n;
    char store[SIDE_MSG];
    size_t used;
} jobject;

const jfield *side_field(const jobject *o, const char *key);       /* NULL: not in the message */
int side_integral(const jfield *f, double lo, double hi);          /* a whole number in [lo, hi] */
/* The message's fields are id, op, k, result (ignored) and those of its op: NULL, or the first other one. */
const char *side_unexpected_field(const jobject *o, const char *const *allowed);

/* ---- writing JSON ------------------------------------------------------------------------------ */
typedef struct {
    char *buf;
    size_t size, n;
    int overflow;                 /* something did not fit: the text is not to be used */
} text;

void side_put(text *t, const char *s, size_t n);
void side_puts(text *t, const char *s);
void side_put_string(text *t, const char *s);     /* a JSON string */
void side_put_int(text *t, int64_t v);
void side_put_double(text *t, double v);          /* as Python's json writes a float */

/* ---- what the model gives the side channel ---------------------------------------------------- */
/* Its telemetry columns (the panel's hello and every row), at most SIDE_MAX_COLUMNS. */
const char *const *model_side_columns(int *n);
void model_side_open(plant *pl);                  /* its steering state at the start of a run */
/* Row k of the telemetry (its columns; after step k-1 and its command u, the rig's reading r). */
void model_side_row(plant *pl, double *row, const reading *r, int64_t late_ns, int64_t compute_ns, double u);
/* What a session's commands.f64 records of the step just taken into out (at most SIDE_MAX_COMMANDS): the
 * valve command (the paper's rig) or every input as applied (a circuit); their count. */
int model_side_commands(plant *pl, double u, double *out);

/* A steering message of the panel (op: not stop, record_start or record_stop) at the boundary before step k.
 * SIDE_APPLIED: applied, its checked fields appended to ev (after {"k": k, "op": ...) and what its answer adds to
 * extra (", \"slot\": 0"); SIDE_REFUSED: nothing changed, the reason in err (the field named); SIDE_UNKNOWN:
 * not one of its operations (MODEL_STEER_OPS). */
enum { SIDE_APPLIED, SIDE_REFUSED, SIDE_UNKNOWN };
int model_steer(plant *pl, const jobject *o, const char *op, int64_t k, text *ev, char *extra, size_t extra_size,
                char *err, size_t err_size);
extern const char MODEL_STEER_OPS[];              /* its operations, for the message naming them */

#endif
