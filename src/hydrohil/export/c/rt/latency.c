/* latency.c: see latency.h. */
#include <math.h>
#include "latency.h"

void latency_add(latency_hist *h, int64_t value_ns)
{
    double us = (double)value_ns / 1e3;
    int i = 0;
    if (us > LAT_LOW_US) {
        double b = log(us / LAT_LOW_US) * (LAT_BINS_PER_DECADE / log(10.0)) + 1.0;
        i = b >= LAT_NBINS - 1 ? LAT_NBINS - 1 : (int)b;
    }
    h->counts[i]++;
    h->n++;
    if (value_ns > h->max_ns)
        h->max_ns = value_ns;
}

double latency_percentile(const latency_hist *h, double q)
{
    double target, lo, centre, max_us = (double)h->max_ns / 1e3;
    int64_t cum = 0;
    int i;
    if (h->n == 0)
        return NAN;
    target = q / 100.0 * (double)h->n;
    if (target < 1.0)
        target = 1.0;
    for (i = 0; i < LAT_NBINS - 1; i++) {
        cum += h->counts[i];
        if ((double)cum >= target)
            break;
    }
    if (i == 0)
        return 0.0;                 /* at or below 0.1 us */
    lo = LAT_LOW_US * pow(10.0, (i - 1) / (double)LAT_BINS_PER_DECADE);
    centre = lo * pow(10.0, 0.5 / LAT_BINS_PER_DECADE);
    return centre < max_us ? centre : max_us;
}

double latency_max_us(const latency_hist *h) { return h->n ? (double)h->max_ns / 1e3 : NAN; }
