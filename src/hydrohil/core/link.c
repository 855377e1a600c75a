/* link.c: the network between a controller and a plant (SPEC §10; docs/protocol.md; the fault types:
 * simulation/faults.py): what the injected network faults of a run's fault table (packet_loss, network_delay,
 * reordering, controller_silence) let through of the command packet sent for each step, then the watchdog
 * (and whether a command_inversion swaps the command's sign at the plant).
 * Any plant's packets: the paper's rig (rig.c) sends one command a packet, a circuit's plant (the generated C
 * includes this file; its Python and standalone plants and its offline loop call hh_path_step) the values of
 * its inputs. Needs rng.c and watchdog.c before it in the translation unit. */

#ifndef HH_CORE_LINKED   /* (hh.h's functions of this part; a translation unit linked with hh_core.c, which defines
                           them, leaves them out: core.h) */
void hh_wire_init(hh_wire *w, int stride, double *fifo, int64_t cap)
{
    w->stride = stride;
    w->fifo = fifo;
    w->cap = fifo ? cap : 0;
    w->head = w->n = 0;
    w->held_back = 0;
}

/* A stream of its own for a fault in slot i of a run's table: splitmix64 from the run's seed and the slot. */
void hh_rng_stream(hh_rng *r, uint64_t seed, int slot)
{
    hh_rng_seed(r, seed ^ (0xD1B54A32D192ED03ULL * (uint64_t)(slot + 1)));
}

void hh_fault_seed(hh_fault *f, uint64_t seed, int slot) { hh_rng_stream(&f->rng, seed, slot); }

uint64_t hh_fault_mask(const hh_fault *f, int n, int64_t k)
{
    uint64_t mask = 0;
    int i;
    for (i = 0; i < n; i++)
        if (f[i].k_start <= k && k < f[i].k_end)
            mask |= (uint64_t)1 << i;
    return mask;
}

/* The packet sent for this step (sent = 0: none) through the active network faults, in slot order: returns 1
 * when a packet reaches the plant (then in packet), 0 when none does (the plant holds its last command). The
 * delay line keeps the newest when a delay shrinks; a packet held back by reordering arrives after its
 * successor and is dropped as stale. */
int hh_wire_deliver(hh_wire *w, hh_fault *fault, int nfault, uint64_t mask, double h, int sent, double *packet)
{
    int64_t delay_steps = 0;
    int i, j, s = w->stride;
    for (i = 0; i < nfault; i++) {
        hh_fault *f = &fault[i];
        if (!(mask >> i & 1))
            continue;
        if (f->type == HH_FAULT_CONTROLLER_SILENCE) {
            sent = 0;
        } else if (f->type == HH_FAULT_PACKET_LOSS) {
            if (sent && hh_rng_uniform(&f->rng) - 0x1.0p-53 < f->a)
                sent = 0;
        } else if (f->type == HH_FAULT_NETWORK_DELAY) {
            int64_t n = (int64_t)nearbyint(f->a / h);
            if (n > delay_steps)
                delay_steps = n;
        } else if (f->type == HH_FAULT_REORDERING && sent) {
            if (w->held_back) {                    /* the held-back packet arrives after this one: stale */
                w->held_back = 0;
            } else if (hh_rng_uniform(&f->rng) - 0x1.0p-53 < f->a) {
                w->held_back = 1;
                sent = 0;
            }
        }
    }
    if (delay_steps > w->cap - 2)                  /* the caller sized the line for the longest delay (none: 0) */
        delay_steps = w->cap > 2 ? w->cap - 2 : 0;
    if (delay_steps || w->n) {
        double *slot = w->fifo + ((w->head + w->n) % w->cap) * (s + 1);
        slot[0] = sent;
        for (j = 0; sent && j < s; j++)
            slot[1 + j] = packet[j];
        w->n++;
        if (w->n <= delay_steps)
            return 0;
        while (w->n > delay_steps + 1) {           /* the delay shrank or ended: the newest wins */
            w->head = (w->head + 1) % w->cap;
            w->n--;
        }
        slot = w->fifo + w->head * (s + 1);
        sent = slot[0] != 0.0;
        for (j = 0; sent && j < s; j++)
            packet[j] = slot[1 + j];
        w->head = (w->head + 1) % w->cap;
        w->n--;
    }
    return sent;
}

void hh_path_init(hh_path *p, hh_fault *fault, int nfault, double h, double timeout, int stride, double *fifo,
                  int64_t cap)
{
    p->fault = fault;
    p->nfault = nfault;
    p->h = h;
    p->timeout = timeout;
    hh_wire_init(&p->wire, stride, fifo, cap);
    hh_watchdog_init(&p->link);
    p->inverted = 0;
    p->hold_kp = 0.0;
}

int hh_path_step(hh_path *p, int64_t k, int sent, double *packet, double x)
{
    uint64_t mask = hh_fault_mask(p->fault, p->nfault, k);
    int got = mask || p->wire.n ? hh_wire_deliver(&p->wire, p->fault, p->nfault, mask, p->h, sent, packet) : sent;
    int i, silenced = 0;
    p->inverted = 0;
    for (i = 0; i < p->nfault; i++)
        if (mask >> i & 1) {
            silenced |= p->fault[i].type == HH_FAULT_CONTROLLER_SILENCE;
            p->inverted |= p->fault[i].type == HH_FAULT_COMMAND_INVERSION;
        }
    if ((sent && !got) || silenced)
        p->link.k_interfered = k;       /* an injected fault held the controller's packet back this step */
    hh_watchdog_command(&p->link, k, got, 0.0, p->h, p->timeout, p->hold_kp > 0.0, p->hold_kp, x);
    return got;
}

/* What a commanded input gets of the value v (the command held, or the safe state's): negated under a
 * command_inversion, saturated to [lo, hi]; *saturated: a command clamped (not the safe state's value). */
static double path_value(const hh_path *p, double v, double lo, double hi, int *saturated)
{
    double c;
    v = p->inverted ? -v : v;
    c = hh_clamp(v, lo, hi);
    if (saturated)
        *saturated = c != v && !p->link.active;
    return c;
}

double hh_path_apply(const hh_path *p, double held, double lo, double hi, int *saturated)
{
    return path_value(p, p->link.active ? 0.0 : held, lo, hi, saturated);
}

double hh_path_apply_held(const hh_path *p, double held, double lo, double hi, double x, int *saturated)
{
    double safe = p->hold_kp > 0.0 ? p->hold_kp * (p->link.hold_x - x) : 0.0;   /* (the rig's p_control law; the
                                                                                   input's range its clamp) */
    return path_value(p, p->link.active ? safe : held, lo, hi, saturated);
}
#endif
