/* step_count.c: runs the core's sampled loop outside Python, for `hydrohil bench` to count the machine
 * instructions of a hybrid step with valgrind/callgrind (a figure that does not depend on machine load).
 *
 *   step_count P.bin U.bin N METHOD H XP0   (P.bin: HH_NP doubles; U.bin: N + 1 commands; METHOD: 0..3;
 *                                         H: step [s]; XP0: start position [m], at rest)
 *
 * Prints the final state. Build: cc -std=c99 -O3 -ffp-contract=off -fno-math-errno -I.. step_count.c
 * ../hh_core.c -lm (the flags of the Python extension, core/build.py). */
#include <stdio.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "hh.h"

static double *read_doubles(const char *path, long n)
{
    double *v = malloc(sizeof(double) * (size_t)n);
    FILE *f = fopen(path, "rb");
    if (!v || !f || fread(v, sizeof(double), (size_t)n, f) != (size_t)n) {
        fprintf(stderr, "step_count: cannot read %ld doubles from %s\n", n, path);
        exit(2);
    }
    fclose(f);
    return v;
}

int main(int argc, char **argv)
{
    static hh_sim sim;
    double *p, *u, *buf, alpha, log[2 * HH_NLOG];
    long n;
    int64_t done, rows;
    int dn, status;
    hh_drive drive;
    if (argc != 7) {
        fprintf(stderr, "usage: step_count P.bin U.bin N METHOD H XP0\n");
        return 2;
    }
    memset(&drive, 0, sizeof drive);   /* open loop, the plant alone (no rig, no callbacks) */
    drive.kind = HH_DRIVE_OPEN;
    n = atol(argv[3]);
    p = read_doubles(argv[1], HH_NP);
    u = read_doubles(argv[2], n + 1);
    dn = hh_delay_steps(p[HH_SPOOL_DELAY], atof(argv[5]), &alpha);
    buf = malloc(sizeof(double) * (size_t)(dn + 2));
    hh_sim_init(&sim, p, HH_MODEL_HYBRID, atoi(argv[4]), atof(argv[5]), buf, dn, alpha);
    hh_initial_state(sim.p, atof(argv[6]), 0.0, 0.0, NAN, NAN, 0.0, sim.y, sim.m);
    hh_sim_reset(&sim);
    drive.v_in = u;
    drive.n_in = n + 1;
    status = hh_sim_run(&sim, &drive, n, n, log, &done, &rows);
    printf("status %d steps %ld xp %.17g p1 %.17g\n", status, (long)done, sim.y[HH_XP], sim.y[HH_P1]);
    return status;
}
