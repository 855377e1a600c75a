/* Platform floor for the real-time plant: what a C program with the plant's duty cycle sees.
 *
 * SCHED_FIFO 50, memory locked, period 0.5 ms: sleep (absolute clock_nanosleep) until 200 us before
 * each period's end, then spin to the end, like `hydrohil plant`. Counts wake-ups later than 0.5 ms
 * (what the plant would count as overruns), later than 1 ms and 10 ms, and gaps inside the spin.
 *
 *   cc -O2 -o hiccup src/hydrohil/core/tools/hiccup.c && ./hiccup 60 [cpu]   (also a section of `hydrohil bench`)
 */
#define _GNU_SOURCE
#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <time.h>

static long long now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec * 1000000000LL + t.tv_nsec;
}

int main(int argc, char **argv) {
    double secs = argc > 1 ? atof(argv[1]) : 60.0;
    int cpu = argc > 2 ? atoi(argv[2]) : -1;
    struct sched_param sp = {.sched_priority = 50};
    if (sched_setscheduler(0, SCHED_FIFO, &sp)) perror("SCHED_FIFO (continuing at normal priority)");
    mlockall(MCL_CURRENT | MCL_FUTURE);
    if (cpu >= 0) {
        cpu_set_t s;
        CPU_ZERO(&s);
        CPU_SET(cpu, &s);
        sched_setaffinity(0, sizeof s, &s);
    }
    const long long period = 500000, spin = 200000;
    long long t0 = now(), end = t0 + (long long)(secs * 1e9), next = t0, periods = 0;
    long long late05 = 0, late1 = 0, late10 = 0, spin_gaps = 0, worst = 0;
    while (next < end) {
        next += period;
        long long wake = next - spin;
        struct timespec ts = {wake / 1000000000LL, wake % 1000000000LL};
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL);
        long long t = now(), late = t - wake;
        periods++;
        late05 += late > 500000;
        late1 += late > 1000000;
        late10 += late > 10000000;
        if (late > worst) worst = late;
        for (long long prev = t; t < next; prev = t) {
            t = now();
            if (t - prev > 100000) spin_gaps++;
            if (t - prev > worst) worst = t - prev;
        }
    }
    printf("{\"periods\": %lld, \"wakeups_late_0.5ms\": %lld, \"late_fraction\": %.5f, \"late_1ms\": %lld, "
           "\"late_10ms\": %lld, \"spin_gaps_100us\": %lld, \"worst_ms\": %.3f}\n",
           periods, late05, (double)late05 / periods, late1, late10, spin_gaps, worst / 1e6);
    return 0;
}
