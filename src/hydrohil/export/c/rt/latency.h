/* latency.h: latency statistics in bounded memory, as hydrohil.hil.stats.LatencyHistogram: log-spaced bins
 * from 0.1 us to 100 s, 200 per decade (1.2 %), percentile = bin centre (capped at the exact maximum). */
#ifndef HHIL_LATENCY_H
#define HHIL_LATENCY_H
#include <stdint.h>

#define LAT_LOW_US 0.1
#define LAT_BINS_PER_DECADE 200
#define LAT_DECADES 9
#define LAT_NBINS (LAT_BINS_PER_DECADE * LAT_DECADES + 2)

typedef struct {
    int64_t counts[LAT_NBINS];
    int64_t n;
    int64_t max_ns;
} latency_hist;

void latency_add(latency_hist *h, int64_t value_ns);
double latency_percentile(const latency_hist *h, double q);   /* us; NaN when empty */
double latency_max_us(const latency_hist *h);                  /* NaN when empty */

#endif
