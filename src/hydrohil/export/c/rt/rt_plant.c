/* rt_plant.c: hydrohil's standalone real-time plant (`hydrohil export c`), no Python on the target.
 *
 * The same virtual rig as `hydrohil plant` (src/hydrohil/hil/plant.py), from the same C core: the hybrid
 * model (RK3 at a fixed step), the rig's command path with its watchdog and safe state and the pressure
 * transducers (core/rig.c), served over UDP with protocol v1 (docs/protocol.md, protocol.c), locked to the
 * wall clock by absolute deadlines (clock_nanosleep TIMER_ABSTIME on CLOCK_MONOTONIC), SCHED_FIFO and
 * mlockall where permitted (reported in timing.json). It writes the same plant_log.csv (streamed by a
 * writer thread: the step loop only copies a row into a ring) and timing.json with the same keys and the
 * VALID / INVALID verdict of hydrohil.hil.verdict.
 *
 * Timeline of step k (h = plant step, t0 = start instant): sleep until t0 + k*h - spin, spin to t0 + k*h
 * reading arrivals, take the latest valid command (or the watchdog's safe command), advance the model one
 * step, send the sensor packet of the state at (k+1)*h. Jitter = start of step k - (t0 + k*h); an overrun
 * is a step that starts after t0 + (k+1)*h. --lockstep replaces the clock by the exchange itself.
 *
 * Exit codes as hydrohil's: 0 VALID, 3 INVALID (logs and verdict complete), 4 no controller / link lost,
 * 1 the model diverged, 2 bad arguments, 130 / 143 stopped by SIGINT / SIGTERM (logs written).
 *
 * This file: the plant's loop and main, whatever it serves: the paper's rig (rt_rig.c) or a circuit generated
 * from its description (rt_circuit.c), behind the model_* functions of rt_plant.h. The command line is
 * rt_options.c, plant_log.csv rt_log.c, timing.json and the verdict rt_report.c (rt_plant.h: what they share).
 */
#define _GNU_SOURCE
#include <arpa/inet.h>
#include <errno.h>
#include <getopt.h>
#include <math.h>
#include <netinet/in.h>
#include <poll.h>
#include <pthread.h>
#include <sched.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "rt_plant.h"

#define SPIN_NS 150000LL          /* busy-wait the last 150 us before a deadline ... */
#define SPIN_FRACTION 0.3         /* ... but at most 30 % of a step (RT throttling) */

/* ---- signals ------------------------------------------------------------------------------------ */
static volatile sig_atomic_t g_signal = 0;

static void on_signal(int sig) { g_signal = sig; }

/* ---- the plant ---------------------------------------------------------------------------------- */


static void send_to_peer(plant *pl, const uint8_t *buf, size_t n)
{
    if (pl->has_peer)
        sendto(pl->sock, buf, n, 0, (const struct sockaddr *)&pl->peer, sizeof pl->peer);
}

void transmit(plant *pl, int64_t k, const uint8_t *buf, size_t n, int64_t t_mono)
{
    sent_stamp *st = &pl->sent[k % SENT_RING];
    st->k = k;
    st->t_mono = t_mono;
    st->t_wall = wall_ns();
    send_to_peer(pl, buf, n);
}

static int same_address(const struct sockaddr_in *a, const struct sockaddr_in *b)
{
    return a->sin_addr.s_addr == b->sin_addr.s_addr && a->sin_port == b->sin_port;
}

static void receive(plant *pl, const uint8_t *data, size_t n, const struct sockaddr_in *from, int64_t t_arr,
                    int64_t t_kernel)
{
    hhil_message msg;
    if (!hhil_decode(data, n, &msg) || !model_accepts(pl, &msg)) {
        pl->packets_bad++;
        return;
    }
    if (!pl->has_peer) {
        pl->peer = *from;
        pl->has_peer = 1;
    } else if (!same_address(from, &pl->peer)) {
        pl->packets_foreign++;
        return;
    }
    pl->packets_rx++;
    if (msg.header.type == HHIL_COMMAND || msg.header.type == HHIL_INPUTS) {
        int64_t seq = msg.header.seq;
        sent_stamp *st;
        if (seq <= pl->cmd_seq) {
            pl->packets_reordered++;
            return;
        }
        if (pl->cmd_seq >= 0 && seq > pl->cmd_seq + 1)
            pl->packets_lost += seq - pl->cmd_seq - 1;
        pl->cmd_seq = seq;
        pl->cmd_echo = msg.header.echo_seq;
        pl->cmd_t_arrival = t_arr;
        model_take(pl, &msg);
        pl->cmd_new = 1;
        st = &pl->sent[msg.header.echo_seq % SENT_RING];
        if (st->k == (int64_t)msg.header.echo_seq) {
            latency_add(&pl->rtt_seen, t_arr - st->t_mono);
            latency_add(&pl->rtt, t_kernel >= 0 ? t_kernel - st->t_wall : t_arr - st->t_mono);
            st->k = -1;
        }
        if ((msg.header.type == HHIL_COMMAND ? msg.command.flags : msg.inputs.flags) & HHIL_CMD_STOP)
            pl->stop_requested = 1;
    } else if (msg.header.type == HHIL_BYE) {
        pl->stop_requested = 1;
    }
}

/* Read the datagrams waiting on the socket (non-blocking), at most `max`, with their kernel arrival stamps. */
static void drain_at_most(plant *pl, int max)
{
    uint8_t data[HHIL_MAX_DATAGRAM + 1];
    char control[256];
    for (; max > 0; max--) {
        struct sockaddr_in from;
        struct iovec iov = {data, sizeof data};
        struct msghdr mh;
        struct cmsghdr *cm;
        int64_t t_kernel = -1;
        ssize_t n;
        memset(&mh, 0, sizeof mh);
        mh.msg_name = &from;
        mh.msg_namelen = sizeof from;
        mh.msg_iov = &iov;
        mh.msg_iovlen = 1;
        mh.msg_control = control;
        mh.msg_controllen = sizeof control;
        n = recvmsg(pl->sock, &mh, MSG_DONTWAIT);
        if (n < 0) {
            if (errno == EINTR)
                continue;
            return;                 /* EAGAIN: empty (other errors, e.g. ICMP refusals: nothing to read) */
        }
        for (cm = CMSG_FIRSTHDR(&mh); cm; cm = CMSG_NXTHDR(&mh, cm)) {
            if (cm->cmsg_level != SOL_SOCKET)
                continue;
            if (cm->cmsg_type == SO_TIMESTAMPNS) {
                struct timespec ts;
                memcpy(&ts, CMSG_DATA(cm), sizeof ts);
                t_kernel = (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
            }
#ifdef SO_RXQ_OVFL
            else if (cm->cmsg_type == SO_RXQ_OVFL) {
                uint32_t drops;
                memcpy(&drops, CMSG_DATA(cm), sizeof drops);
                pl->packets_dropped_kernel = drops;
            }
#endif
        }
        receive(pl, data, (size_t)n, &from, mono_ns(), t_kernel);
    }
}

static void drain(plant *pl) { drain_at_most(pl, 1 << 30); }

static void check_signal(plant *pl)
{
    if (g_signal) {
        pl->stop_requested = 1;
        pl->stop_signal = g_signal;
    }
}

/* Wait for step k's instant `deadline`: sleep on the socket until spin_ns before it (reading arrivals as
 * they come, as the Python plant's select does), then clock_nanosleep to that absolute instant (the
 * remainder ppoll's relative timeout left), then spin to the deadline reading arrivals. */
static void wait_until(plant *pl, int64_t deadline)
{
    int64_t wake = deadline - pl->spin_ns, left;
    struct pollfd fd = {0, POLLIN, 0};
    fd.fd = pl->sock;
    while ((left = wake - mono_ns()) > 0 && !pl->stop_requested) {
        struct timespec rel = {(time_t)(left / 1000000000LL), (long)(left % 1000000000LL)};
        if (ppoll(&fd, 1, &rel, NULL) > 0)
            drain(pl);
        check_signal(pl);
    }
    if (wake > mono_ns() && !pl->stop_requested) {
        struct timespec ts = {(time_t)(wake / 1000000000LL), (long)(wake % 1000000000LL)};
        while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, NULL) == EINTR) {
            check_signal(pl);
            if (pl->stop_requested)
                break;
        }
    }
    while (mono_ns() < deadline)
        drain(pl);
}

/* Block until the command answering sensor packet k arrives (lock-step); a controller silent for
 * [hil] link_timeout ends the run with a link error. */
static void wait_lockstep(plant *pl, int64_t k)
{
    int64_t limit = mono_ns() + (int64_t)(pl->o->hil[HIL_LINK_TIMEOUT] * 1e9);
    while (pl->cmd_echo < k && !pl->stop_requested) {
        int64_t left = limit - mono_ns();
        struct pollfd fd = {pl->sock, POLLIN, 0};
        if (left <= 0) {
            char bad[64] = "";
            if (pl->packets_bad)
                snprintf(bad, sizeof bad, "; %lld bad packets came", (long long)pl->packets_bad);
            snprintf(pl->link_error, sizeof pl->link_error, "controller silent for %g s at step %lld (lock-step%s)",
                     pl->o->hil[HIL_LINK_TIMEOUT], (long long)k, bad);
            pl->stop_requested = 1;
            return;
        }
        if (poll(&fd, 1, (int)(left < 200000000LL ? left / 1000000 + 1 : 200)) > 0)
            drain(pl);
        check_signal(pl);
    }
}

/* Block until a valid packet from the (configured or first) controller, at most [hil] connect_timeout; the
 * panel is served meanwhile ("stop" at once, the rest at step 0). */
static int wait_for_controller(plant *pl)
{
    int64_t end = mono_ns() + (int64_t)(pl->o->hil[HIL_CONNECT_TIMEOUT] * 1e9);
    while (pl->packets_rx == 0 && !pl->stop_requested) {
        int64_t left = end - mono_ns();
        struct pollfd fd[2] = {{pl->sock, POLLIN, 0}, {side_fd(pl), POLLIN, 0}};
        if (left <= 0)
            return 0;
        if (poll(fd, fd[1].fd >= 0 ? 2 : 1, (int)(left < 200000000LL ? left / 1000000 + 1 : 200)) > 0) {
            if (fd[0].revents)
                drain_at_most(pl, 1);   /* one at a time: a command queued behind the HELLO is step 0's */
            if (fd[1].fd >= 0 && fd[1].revents)
                side_poll_waiting(pl);
        }
        check_signal(pl);
    }
    return pl->packets_rx > 0;
}

/* What step k uses: the command that arrived for it (1, *u) or none (0). Counts a late command. */
static int take_command(plant *pl, int64_t k, double *u)
{
    if (pl->cmd_echo < k && !pl->link->active)
        pl->late_commands++;
    if (!pl->cmd_new)
        return 0;
    pl->cmd_new = 0;
    *u = pl->cmd_u;
    return 1;
}

/* The name Python gives an OS error (the Python plant reports "not permitted (PermissionError)"). */
static const char *error_name(int err)
{
    return err == EPERM || err == EACCES ? "PermissionError" : err == EINVAL ? "OSError (EINVAL)" : "OSError";
}

static void realtime_setup(plant *pl)
{
    const options *o = pl->o;
    snprintf(pl->os_cpu, sizeof pl->os_cpu, "null");
    if (o->cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(o->cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) == 0)
            snprintf(pl->os_cpu, sizeof pl->os_cpu, "%d", o->cpu);
        else
            snprintf(pl->os_cpu, sizeof pl->os_cpu, "\"not permitted (%s)\"", error_name(errno));
        if (pl->log.started)        /* the whole process on the plant's CPU: the writers take its idle time */
            pthread_setaffinity_np(pl->log.thread, sizeof set, &set);
        if (pl->side.w.started)
            pthread_setaffinity_np(pl->side.w.thread, sizeof set, &set);
    }
    if (o->lockstep) {
        snprintf(pl->os_rt, sizeof pl->os_rt, "lock-step");
        return;
    }
    if (pl->spin) {    /* a SCHED_FIFO task that never sleeps is stopped by the kernel's RT throttling */
        if (setpriority(PRIO_PROCESS, 0, -20) == 0)
            snprintf(pl->os_rt, sizeof pl->os_rt, "normal policy, nice -20 (spin)");
        else
            snprintf(pl->os_rt, sizeof pl->os_rt, "not permitted (%s); normal priority", error_name(errno));
    } else {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = 50;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0)
            snprintf(pl->os_rt, sizeof pl->os_rt, "SCHED_FIFO 50");
        else
            snprintf(pl->os_rt, sizeof pl->os_rt, "not permitted (%s); normal priority", error_name(errno));
    }
    pl->timer_slack = prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0;
    pl->memory_locked = mlockall(MCL_CURRENT | MCL_FUTURE) == 0;   /* no paging in the loop */
}

/* ---- main --------------------------------------------------------------------------------------- */
static int open_socket(plant *pl)
{
    int one = 1, rcvbuf = 1 << 20;
    socklen_t len = sizeof pl->o->bind;
    struct sockaddr_in bound;
    pl->sock = socket(AF_INET, SOCK_DGRAM, 0);
    if (pl->sock < 0) {
        fprintf(stderr, "error: socket: %s\n", strerror(errno));
        return -1;
    }
    setsockopt(pl->sock, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
#ifdef SO_RXQ_OVFL
    setsockopt(pl->sock, SOL_SOCKET, SO_RXQ_OVFL, &one, sizeof one);
#endif
    pl->kernel_stamps = setsockopt(pl->sock, SOL_SOCKET, SO_TIMESTAMPNS, &one, sizeof one) == 0;
    if (bind(pl->sock, (const struct sockaddr *)&pl->o->bind, sizeof pl->o->bind) < 0) {
        fprintf(stderr, "error: cannot bind %s: %s\n", pl->o->bind_text, strerror(errno));
        return -1;
    }
    getsockname(pl->sock, (struct sockaddr *)&bound, &len);
    {
        char host[INET_ADDRSTRLEN];
        inet_ntop(AF_INET, &bound.sin_addr, host, sizeof host);
        printf("READY %s:%d\n", host, ntohs(bound.sin_port));
        fflush(stdout);
    }
    return 0;
}

static int plant_init(plant *pl, options *o)
{
    memset(pl, 0, sizeof *pl);
    pl->o = o;
    if (model_init(pl) < 0)
        return -1;
    pl->n = o->duration > 0 ? (int64_t)nearbyint(o->duration / o->step)   /* half to even, as Python's round() */
                            : INT32_MAX - 1;                          /* 0: until stopped (u32 sequence numbers) */
    pl->h_ns = (int64_t)nearbyint(o->step * 1e9);
    pl->spin = o->hil[HIL_WAIT] == HIL_WAIT_SPIN;
    pl->spin_ns = pl->spin ? 2 * pl->h_ns : (int64_t)fmin((double)SPIN_NS, SPIN_FRACTION * (double)pl->h_ns);
    pl->cmd_seq = pl->cmd_echo = -1;
    {
        int i;
        for (i = 0; i < SENT_RING; i++)
            pl->sent[i].k = -1;
    }
    return 0;
}

int make_dirs(const char *dir)
{
    char path[4096];
    size_t i, n = strlen(dir);
    if (n >= sizeof path)
        return -1;
    memcpy(path, dir, n + 1);
    for (i = 1; i <= n; i++) {
        if (path[i] == '/' || path[i] == '\0') {
            char c = path[i];
            path[i] = '\0';
            if (mkdir(path, 0777) != 0 && errno != EEXIST)
                return -1;
            path[i] = c;
        }
    }
    return 0;
}

int main(int argc, char **argv)
{
    static options o;
    static plant pl;
    static char reasons[8][REASON_SIZE];
    struct sigaction sa;
    int64_t t0, t_end, last_start, k, k_done = 0, drift_ns;
    uint32_t status_extra = 0;
    int nreasons, code;
    FILE *timing_fh = NULL;
    char path[4096];

    parse_options(argc, argv, &o);
    memset(&sa, 0, sizeof sa);
    sigemptyset(&sa.sa_mask);
    sa.sa_handler = on_signal;          /* no SA_RESTART: sleeps and polls return at a signal */
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);
    if (o.log_dir) {
        snprintf(path, sizeof path, "%s/timing.json.part", o.log_dir);
        if (make_dirs(o.log_dir) != 0 || !(timing_fh = fopen(path, "w"))) {   /* can we write there? */
            fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
            return 2;
        }
        fclose(timing_fh);
        unlink(path);                   /* written at the end, then renamed: never a partial timing.json */
        timing_fh = NULL;
    }
    if (plant_init(&pl, &o) < 0)
        return 2;
    if (log_open(&pl.log, model_log_columns(), o.no_rows ? NULL : o.log_dir, path, sizeof path) < 0) {
        fprintf(stderr, "error: %s\n", path);
        return 2;
    }
    if (side_open(&pl) < 0)
        return 2;
    if (o.has_peer) {
        pl.peer = o.peer;
        pl.has_peer = 1;
    }
    model_warm_up(&pl);            /* the first step of the run pays no page faults */
    if (open_socket(&pl) < 0)
        return 2;
    realtime_setup(&pl);               /* after the writer thread started: it keeps the normal policy */
    check_signal(&pl);

    if (!wait_for_controller(&pl)) {
        if (!pl.stop_requested)
            snprintf(pl.link_error, sizeof pl.link_error, "no controller packet within %g s (%lld bad, %lld foreign "
                     "packets)", o.hil[HIL_CONNECT_TIMEOUT], (long long)pl.packets_bad, (long long)pl.packets_foreign);
        t0 = t_end = mono_ns();
        drift_ns = 0;
    } else {
        char host[INET_ADDRSTRLEN];
        inet_ntop(AF_INET, &pl.peer.sin_addr, host, sizeof host);
        printf("PEER %s:%d\n", host, ntohs(pl.peer.sin_port));
        fflush(stdout);
        pl.cmd_new = 0;                 /* HELLO / early packets are not commands for step 0 */
        t0 = mono_ns() + 2 * pl.h_ns;
        last_start = t0;
        pl.t0 = t0;
        model_send_sensor(&pl, 0, 0);
        model_log_row(&pl, 0, 0.0, 0, 0, 0.0);
        side_apply_queued(&pl);         /* steering that came while waiting for the controller: at boundary 0 */
        for (k = 0; k < pl.n; k++) {
            int64_t start, late, end;
            double u = 0.0;
            int arrived;
            if (o.lockstep) {
                wait_lockstep(&pl, k);
                start = mono_ns();
                late = 0;
            } else {
                int64_t deadline = t0 + k * pl.h_ns;
                wait_until(&pl, deadline);
                start = last_start = mono_ns();
                drain(&pl);
                late = start - deadline;
                status_extra = late > pl.h_ns ? HH_ST_OVERRUN : 0;
                pl.overruns += late > pl.h_ns;
            }
            check_signal(&pl);
            arrived = take_command(&pl, k, &u);
            if (model_step(&pl, k, arrived, &u) != 0) {
                model_send_sensor(&pl, k + 1, HH_ST_FAULT | HH_ST_FINAL);
                break;
            }
            model_send_sensor(&pl, k + 1, status_extra | ((k + 1 == pl.n || pl.stop_requested) ? HH_ST_FINAL : 0));
            end = mono_ns();
            latency_add(&pl.jitter, late);
            latency_add(&pl.compute, end - start);
            k_done = k + 1;
            model_log_row(&pl, k + 1, o.lockstep ? 0.0 : (double)(start - t0) / 1e9, late, end - start, u);
            side_row(&pl, k + 1, &pl.reading, late, end - start, u);
            if (pl.stop_requested)
                break;
        }
        t_end = mono_ns();
        drain(&pl);                     /* count what arrived up to the end (fuzzing, a controller's last words) */
        {
            uint8_t bye[HHIL_SIMPLE_LEN];
            hhil_header h = {HHIL_BYE, (uint32_t)(k_done + 1), t_end, 0, 0};
            int i;
            hhil_encode_simple(bye, &h);
            for (i = 0; i < 3; i++)     /* tell the controller the run is over */
                send_to_peer(&pl, bye, sizeof bye);
        }
        drift_ns = last_start - (t0 + (k_done > 1 ? k_done - 1 : 0) * pl.h_ns);
    }
    log_close(&pl.log);
    side_close(&pl, k_done);            /* a recording still open ends here; the session's files closed */
    nreasons = write_timing(&pl, k_done, t0, t_end, drift_ns, stderr, reasons);   /* as the Python plant */
    if (o.log_dir) {
        char final_path[4096];
        timing_fh = fopen(path, "w");
        if (!timing_fh) {
            fprintf(stderr, "error: cannot write %s: %s\n", path, strerror(errno));
        } else {
            write_timing(&pl, k_done, t0, t_end, drift_ns, timing_fh, reasons);
            fclose(timing_fh);
            snprintf(final_path, sizeof final_path, "%s/timing.json", o.log_dir);
            rename(path, final_path);
        }
    }
    if (pl.link_error[0])
        fprintf(stderr, "error: %s\n", pl.link_error);
    if (pl.fault[0])
        fprintf(stderr, "error: %s\n", pl.fault);
    if (nreasons) {
        int i;
        printf("verdict: INVALID: ");
        for (i = 0; i < nreasons; i++)
            printf("%s%s", i ? "; " : "", reasons[i]);
        printf("\n");
    } else {
        printf("verdict: VALID\n");
    }
    fflush(stdout);
    code = pl.link_error[0] ? 4 : pl.fault[0] ? 1 : pl.stop_signal ? 128 + pl.stop_signal : nreasons ? 3 : 0;
    close(pl.sock);
    model_free(&pl);
    return code;
}
