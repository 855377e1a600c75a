/* A P position controller for the hydrohil plant, written from docs/protocol.md alone.
 *
 *   cc -O2 -o p_controller p_controller.c -lz
 *   hydrohil plant --bind 127.0.0.1:47000 --duration 6 &
 *   ./p_controller 127.0.0.1 47000 50 0.10      # Kp = 50 1/m, hold x_ref = 0.10 m
 *   ./p_controller 127.0.0.1 47000 50 0.10 2    # give up after 2 s without a packet (default 5 s)
 *
 * Exit codes as hydrohil's: 0 done, 2 bad arguments, 4 no plant answered (or it went silent).
 * Little-endian host assumed (x86, ARM); CRC-32 from zlib.
 */
#include <arpa/inet.h>
#include <errno.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <time.h>
#include <unistd.h>
#include <zlib.h>

enum { T_SENSOR = 1, T_COMMAND = 2, T_HELLO = 3, T_BYE = 4 };
enum { SENSOR_LEN = 100, COMMAND_LEN = 52, HELLO_LEN = 36 };
enum { ST_WATCHDOG = 1 << 0, ST_FINAL = 1 << 9 };

static int64_t now_ns(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000000 + ts.tv_nsec;
}

static void header(uint8_t *b, uint16_t type, uint32_t seq, int64_t echo_t, uint32_t echo_seq) {
    uint16_t version = 1;
    int64_t t = now_ns();
    memcpy(b, "HHIL", 4);
    memcpy(b + 4, &version, 2);
    memcpy(b + 6, &type, 2);
    memcpy(b + 8, &seq, 4);
    memcpy(b + 12, &t, 8);
    memcpy(b + 20, &echo_t, 8);
    memcpy(b + 28, &echo_seq, 4);
}

static void seal(uint8_t *b, size_t len) {
    uint32_t crc = (uint32_t)crc32(0L, b, (uInt)(len - 4));
    memcpy(b + len - 4, &crc, 4);
}

static int valid(const uint8_t *b, ssize_t n) {
    uint16_t version, type;
    uint32_t crc;
    if (n < 36 || memcmp(b, "HHIL", 4) != 0) return 0;
    memcpy(&version, b + 4, 2);
    memcpy(&type, b + 6, 2);
    if (version != 1) return 0;
    if (!((type == T_SENSOR && n == SENSOR_LEN) || (type == T_BYE && n == HELLO_LEN))) return 0;
    memcpy(&crc, b + n - 4, 4);
    return crc == (uint32_t)crc32(0L, b, (uInt)(n - 4));
}

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: %s HOST PORT KP X_REF_M [TIMEOUT_S]\n", argv[0]);
        return 2;
    }
    double kp = atof(argv[3]), x_ref = atof(argv[4]), resolution = 1e-6; /* 1 um encoder */
    double timeout_s = argc > 5 ? atof(argv[5]) : 5.0;
    int s = socket(AF_INET, SOCK_DGRAM, 0);
    if (s < 0) {
        perror("socket");
        return 4;
    }
    struct sockaddr_in a = {0};
    a.sin_family = AF_INET;
    a.sin_port = htons((uint16_t)atoi(argv[2]));
    if (timeout_s <= 0 || inet_pton(AF_INET, argv[1], &a.sin_addr) != 1) {
        fprintf(stderr, "error: bad HOST %s or TIMEOUT_S\n", argv[1]);
        return 2;
    }
    if (connect(s, (struct sockaddr *)&a, sizeof a) < 0) {
        perror("connect");
        return 4;
    }
    struct timeval poll_tv = {0, 200000};   /* wake every 0.2 s: say HELLO again until the plant answers */
    setsockopt(s, SOL_SOCKET, SO_RCVTIMEO, &poll_tv, sizeof poll_tv);

    uint8_t out[COMMAND_LEN], in[512];
    uint32_t seq = 0;
    memset(out, 0, sizeof out);
    header(out, T_HELLO, seq, 0, 0);
    seal(out, HELLO_LEN);
    send(s, out, HELLO_LEN, 0);

    long packets = 0;
    int64_t last_heard = now_ns();
    for (;;) {
        ssize_t n = recv(s, in, sizeof in, 0);
        if (n < 0) {                /* timeout, plant not listening (ECONNREFUSED), a signal, or another error */
            if (now_ns() - last_heard > (int64_t)(timeout_s * 1e9)) {
                if (packets == 0)
                    fprintf(stderr, "error: no answer from a plant at %s:%s within %g s (is it running?)\n",
                            argv[1], argv[2], timeout_s);
                else
                    fprintf(stderr, "error: the plant went silent for %g s after %ld packets\n", timeout_s, packets);
                close(s);
                return 4;
            }
            if (packets == 0) {     /* the plant may start after us: HELLO again */
                if (errno == ECONNREFUSED) usleep(10000);
                header(out, T_HELLO, seq, 0, 0);
                seal(out, HELLO_LEN);
                send(s, out, HELLO_LEN, 0);
            }
            continue;
        }
        if (n <= 0 || !valid(in, n)) continue;
        last_heard = now_ns();
        if (packets == 0) {          /* from now on a silence of timeout_s is the plant's, not a slow start */
            struct timeval tv = {(time_t)timeout_s, (suseconds_t)((timeout_s - (time_t)timeout_s) * 1e6)};
            setsockopt(s, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
        }
        uint16_t type;
        memcpy(&type, in + 6, 2);
        if (type == T_BYE) break;
        uint32_t sensor_seq, status;
        int64_t sensor_t, counts;
        double t_sim;
        memcpy(&sensor_seq, in + 8, 4);
        memcpy(&sensor_t, in + 12, 8);
        memcpy(&t_sim, in + 32, 8);
        memcpy(&counts, in + 48, 8);
        memcpy(&status, in + 88, 4);

        double x = (double)counts * resolution;
        double u = kp * (x_ref - x);
        if (u > 1.0) u = 1.0;
        if (u < -1.0) u = -1.0;

        uint32_t flags = 0, reserved = 0;
        memset(out, 0, sizeof out);
        header(out, T_COMMAND, ++seq, sensor_t, sensor_seq);
        memcpy(out + 32, &u, 8);
        memcpy(out + 40, &flags, 4);
        memcpy(out + 44, &reserved, 4);
        seal(out, COMMAND_LEN);
        send(s, out, COMMAND_LEN, 0);
        if (++packets % 2000 == 0)
            printf("t = %.3f s  x = %.6f m  u = %+.4f%s\n", t_sim, x, u, (status & ST_WATCHDOG) ? "  [watchdog]" : "");
        if (status & ST_FINAL) break;
    }
    printf("done: %ld sensor packets answered\n", packets);
    close(s);
    return 0;
}
