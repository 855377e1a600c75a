/* paper_circuit_c.c: the paper's rig as a generated circuit beside the hand-written core, each in a plain C loop
 * (benchmarks/paper_circuit_c.py writes the data headers and builds it twice, -DCIRCUIT or not): Fig 10's open
 * loop, one log row every 1000 steps, N steps per run, R runs; prints the ns per step of each run. */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include "bench_data.h"                 /* N, R, the parameters, the state at rest, the commands' file */

static double now(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static double *read_doubles(const char *path, size_t n)
{
    double *v = malloc(sizeof(double) * n);
    FILE *f = fopen(path, "rb");
    if (!v || !f || fread(v, sizeof(double), n, f) != n) {
        fprintf(stderr, "cannot read %s\n", path);
        exit(1);
    }
    fclose(f);
    return v;
}

#ifdef CIRCUIT
int hc_run(const double *P, double *y, int64_t *m, int method, double h, int64_t n, int64_t every, double *u,
           double *log, int64_t *rows, const void *ctl, void *ctl_state, const double *ref, const double *dref,
           int64_t meas, int64_t cmd, double *sensor, void *rng, double sign, void *path, double lo, double hi,
           double *sent, double *press, void *command, void *command_ctx, double *seen_log,
           double *events_log, double *watchdog_log, int64_t *steps, void *progress, void *progress_ctx,
           const int64_t *cols, int64_t ncols);

int main(void)
{
    double *u = read_doubles(COMMANDS, N + 1), *log = malloc(sizeof(double) * (N / 1000 + 2) * NLOGC);
    double *seen = malloc(sizeof(double) * (N / 1000 + 2)), *events = malloc(sizeof(double) * (N / 1000 + 2));
    double y[sizeof Y0 / sizeof Y0[0]];
    int64_t m[sizeof M0 / sizeof M0[0]], rows;
    int r;
    for (r = 0; r < R; r++) {
        double t0;
        memcpy(y, Y0, sizeof y);
        memcpy(m, M0, sizeof m);
        t0 = now();
        if (hc_run(P0, y, m, 2, STEP, N, 1000, u, log, &rows, 0, 0, 0, 0, 0, 0, 0, 0, 1.0, 0, 0.0, 0.0, 0, 0, 0, 0, seen,
                   events, 0, 0, 0, 0, 0, 0) != 0) {   /* (its spool's input and events logged, as the core's log has them) */
            fprintf(stderr, "the circuit's run stopped before its end\n");
            return 1;
        }
        printf("%.3f ", (now() - t0) / N * 1e9);
    }
    printf("\nxp %.17g\n", y[XP_INDEX]);
    return 0;
}
#else
#include "hh.h"

int main(void)
{
    double *u = read_doubles(COMMANDS, N + 1), *log = malloc(sizeof(double) * (N / 1000 + 2) * HH_NLOG);
    double p[HH_NP], alpha, *dbuf;
    hh_sim sim;
    hh_drive drive;
    int64_t done, rows;
    int r, nd;
    memcpy(p, PC, sizeof p);
    hh_params_derive(p);
    nd = hh_delay_steps(p[HH_SPOOL_DELAY], STEP, &alpha);
    dbuf = calloc((size_t)nd + 2, sizeof(double));
    memset(&drive, 0, sizeof drive);
    drive.kind = HH_DRIVE_OPEN;
    drive.v_in = u;
    for (r = 0; r < R; r++) {
        double t0;
        hh_sim_init(&sim, p, HH_MODEL_HYBRID, HH_RK3, STEP, dbuf, nd, alpha);
        hh_initial_state(p, XP0, XS0, 0.0, NAN, NAN, 0.0, sim.y, sim.m);
        hh_sim_reset(&sim);
        t0 = now();
        if (hh_sim_run(&sim, &drive, N, 1000, log, &done, &rows) != HH_OK) {
            fprintf(stderr, "the core's run stopped before its end\n");
            return 1;
        }
        printf("%.3f ", (now() - t0) / N * 1e9);
    }
    printf("\nxp %.17g\n", sim.y[HH_XP]);
    return 0;
}
#endif
