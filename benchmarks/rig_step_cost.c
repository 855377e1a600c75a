/* rig_step_cost.c: the C plant's compute per step with faults off, before and after the rig step of issue
 * #26 (run by benchmarks/rig_step_cost.py under callgrind: instructions, independent of load).
 *
 *   rig_step_cost P.bin MODE STEPS
 *
 * MODE 0: the pieces the standalone C plant called per step before #26 (the command path's watchdog, the
 * core's step, the transducers' reading); MODE 1: what it calls now (hh_rig_step with an empty fault table,
 * hh_rig_sense: the same work plus the status bits and the fault hooks). A 0.2 ū sine at 1 Hz drives the
 * paper's rig from 0.09 m. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "hh.h"

int main(int argc, char **argv)
{
    static hh_sim sim;
    static hh_rig rig;
    static double p[HH_NP], buf[64];
    hh_watchdog w;
    hh_rng rng;
    hh_reading r;
    hh_rig_reading rr;
    double alpha, u, sink = 0.0;
    long n, k;
    int mode, dn;
    FILE *f;
    if (argc != 4) {
        fprintf(stderr, "usage: rig_step_cost P.bin MODE STEPS\n");
        return 2;
    }
    mode = atoi(argv[2]);
    n = atol(argv[3]);
    f = fopen(argv[1], "rb");
    if (!f || fread(p, sizeof(double), HH_NP, f) != HH_NP)
        return 2;
    fclose(f);
    dn = hh_delay_steps(p[HH_SPOOL_DELAY], 5e-4, &alpha);
    if (dn + 2 > 64)
        return 2;
    hh_sim_init(&sim, p, HH_MODEL_HYBRID, HH_RK3, 5e-4, buf, dn, alpha);
    hh_initial_state(sim.p, 0.09, NAN, 0.0, NAN, NAN, 0.0, sim.y, sim.m);
    hh_sim_reset(&sim);
    hh_watchdog_init(&w);
    hh_rng_seed(&rng, 0);
    hh_rig_init(&rig, &sim, 1e-6, 0, 0.05, 0, 50.0, NULL, 0);
    hh_rig_begin(&rig, 0);
    for (k = 0; k < n; k++) {
        double cmd = 0.2 * sin((double)k * 5e-4 * 6.283185307179586);
        if (mode == 0) {
            u = hh_watchdog_command(&w, k, 1, cmd, 5e-4, 0.05, 0, 50.0, sim.out[HH_OUT_Y + HH_XP]);
            hh_sim_step(&sim, u);
            hh_rig_read(&sim, 1e-6, &rng, &r);
            sink += r.p[HH_PRESSURE_P1] + (double)r.encoder;
        } else {
            hh_rig_step(&rig, k, 1, cmd, &u);
            hh_rig_sense(&rig, &rr);
            sink += rr.p[HH_PRESSURE_P1] + (double)rr.encoder;
        }
    }
    printf("%.17g %.17g\n", sink, sim.y[HH_XP]);
    return 0;
}
