/*
 * Host harness of the ORNI-DAQ9 firmware: the portable core (../src) built with the host's C
 * compiler, acting as the board on stdin/stdout (give it the master end of a pty) so the Python
 * driver can be tested against the very code the RP2040 runs. Only the hardware differs: samples
 * come from a deterministic synthetic source instead of the ADS8688, and the sample clock is the
 * host's monotonic clock instead of the RP2040's PWM timer.
 *
 *   daq9_host crc TEXT    print the CRC-16/CCITT-FALSE of TEXT's bytes as 4 hex digits
 *   daq9_host encode      per stdin line "COUNTER STATUS C0 .. C7", print the frame in hex
 *   daq9_host sample      per stdin line "COUNTER HALL C0 .. C7", print the frame the board sends
 *                         (status computed by the board: Hall bit, over-range bit)
 *   daq9_host serve [--serial TEXT] [--first-counter N]
 *                         be the board on stdin/stdout until the line closes
 *
 * Synthetic source of sample n (n = the frame's counter): ADC code of channel k is
 * (n * MULTIPLIER[k] + 4099 k) mod 65536, offset binary like the ADS8688; channel 2 is at the top
 * code 0xFFFF (over-range) when n mod 1000 = 999; the Hall line is high when bit 5 of n is set.
 * While the output buffer is full the source waits (no sample is dropped), so the stream is the
 * same however fast the reader is.
 */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <math.h>
#include <poll.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "daq9_board.h"
#include "daq9_crc16.h"
#include "daq9_frame.h"

#define OUTPUT_CAPACITY 65536u
#define REPLY_RESERVE 1024u /* output room kept free of frames for the reply lines, bytes */
#define STREAM_TICK_MS 1    /* while streaming, frames due are written at least this often, ms */

static const uint32_t MULTIPLIER[DAQ9_ANALOG_CHANNELS] = {40503u, 9973u, 30011u, 1021u,
                                                          65521u, 257u,  12347u, 77u};

typedef struct {
    uint8_t data[OUTPUT_CAPACITY];
    size_t start, end; /* bytes data[start..end) wait to be written */
} output;

static size_t output_room(const output *out)
{
    return OUTPUT_CAPACITY - (out->end - out->start);
}

static void output_append(output *out, const void *bytes, size_t length)
{
    if (out->end + length > OUTPUT_CAPACITY) {
        memmove(out->data, out->data + out->start, out->end - out->start);
        out->end -= out->start;
        out->start = 0;
    }
    memcpy(out->data + out->end, bytes, length);
    out->end += length;
}

static void output_line(output *out, const char *line)
{
    output_append(out, line, strlen(line));
    output_append(out, "\n", 1);
}

static void synthetic_sample(uint32_t n, int16_t counts[DAQ9_ANALOG_CHANNELS], bool *hall_high)
{
    for (uint32_t k = 0; k < DAQ9_ANALOG_CHANNELS; k++) {
        uint16_t code = (uint16_t)(n * MULTIPLIER[k] + 4099u * k);
        if (k == 2u && n % 1000u == 999u) {
            code = 0xFFFFu;
        }
        counts[k] = daq9_counts_from_offset_binary(code);
    }
    *hall_high = ((n >> 5) & 1u) != 0u;
}

static double seconds_since(const struct timespec *start)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)(now.tv_sec - start->tv_sec) + 1e-9 * (double)(now.tv_nsec - start->tv_nsec);
}

typedef struct {
    daq9_board board;
    output out;
    struct timespec started;
    uint64_t taken; /* samples taken since START */
} harness;

/* Take every sample the clock has made due since START, as far as the output has room. */
static void take_due_samples(harness *h)
{
    double due = floor(seconds_since(&h->started) * h->board.rate.rate_hz);
    while ((double)h->taken < due && output_room(&h->out) >= DAQ9_FRAME_BYTES + REPLY_RESERVE) {
        int16_t counts[DAQ9_ANALOG_CHANNELS];
        bool hall_high;
        uint8_t frame[DAQ9_FRAME_BYTES];
        synthetic_sample(h->board.next_counter, counts, &hall_high);
        daq9_board_take_sample(&h->board, counts, hall_high, frame);
        output_append(&h->out, frame, sizeof frame);
        h->taken++;
    }
}

static void handle_byte(harness *h, uint8_t byte)
{
    if (!daq9_board_feed(&h->board, byte)) {
        return;
    }
    char reply[DAQ9_REPLY_CAPACITY];
    switch (daq9_board_handle_line(&h->board, reply, sizeof reply)) {
    case DAQ9_ACTION_NONE:
        break;
    case DAQ9_ACTION_REPLY:
        output_line(&h->out, reply);
        break;
    case DAQ9_ACTION_START:
        output_line(&h->out, reply);
        clock_gettime(CLOCK_MONOTONIC, &h->started);
        h->taken = 0;
        break;
    case DAQ9_ACTION_STOP:
        take_due_samples(h); /* the samples already taken go out before the stop marker */
        output_line(&h->out, reply);
        break;
    }
}

static int serve(const char *serial_number, uint32_t first_counter)
{
    static harness h;
    daq9_config config = {serial_number, DAQ9_REFERENCE_RANGE_V, DAQ9_REFERENCE_HALL_HIGH_V,
                          DAQ9_REFERENCE_BAUD, DAQ9_REFERENCE_TIMER_CLOCK_HZ};
    daq9_board_init(&h.board, &config);
    h.board.next_counter = first_counter;
    fcntl(STDIN_FILENO, F_SETFL, fcntl(STDIN_FILENO, F_GETFL) | O_NONBLOCK);
    fcntl(STDOUT_FILENO, F_SETFL, fcntl(STDOUT_FILENO, F_GETFL) | O_NONBLOCK);
    for (;;) {
        if (h.board.streaming) {
            take_due_samples(&h);
        }
        struct pollfd fds[2] = {{STDIN_FILENO, POLLIN, 0}, {STDOUT_FILENO, 0, 0}};
        if (h.out.end > h.out.start) {
            fds[1].events = POLLOUT;
        }
        if (poll(fds, 2, h.board.streaming ? STREAM_TICK_MS : -1) < 0 && errno != EINTR) {
            return 1;
        }
        if (fds[0].revents & (POLLHUP | POLLERR | POLLNVAL)) {
            return 0; /* the other end of the line is gone */
        }
        if (fds[0].revents & POLLIN) {
            uint8_t incoming[256];
            ssize_t n = read(STDIN_FILENO, incoming, sizeof incoming);
            if (n == 0 || (n < 0 && errno != EAGAIN && errno != EINTR)) {
                return 0;
            }
            for (ssize_t i = 0; i < n; i++) {
                handle_byte(&h, incoming[i]);
            }
        }
        if (fds[1].revents & POLLOUT) {
            ssize_t n = write(STDOUT_FILENO, h.out.data + h.out.start, h.out.end - h.out.start);
            if (n < 0 && errno != EAGAIN && errno != EINTR) {
                return 0;
            }
            if (n > 0) {
                h.out.start += (size_t)n;
            }
        }
    }
}

static void print_frame(const uint8_t frame[DAQ9_FRAME_BYTES])
{
    for (unsigned i = 0; i < DAQ9_FRAME_BYTES; i++) {
        printf(i ? " %02x" : "%02x", frame[i]);
    }
    printf("\n");
}

/* Frames from stdin records "COUNTER X C0 .. C7": X is the status byte (`board_status` false) or
 * the Hall level whose status the board computes (`board_status` true). */
static int frames_from_records(bool board_status)
{
    long long counter;
    unsigned long x;
    long c[DAQ9_ANALOG_CHANNELS];
    while (scanf("%lli %lu %ld %ld %ld %ld %ld %ld %ld %ld", &counter, &x, &c[0], &c[1],
                 &c[2], &c[3], &c[4], &c[5], &c[6], &c[7]) == 10) {
        int16_t counts[DAQ9_ANALOG_CHANNELS];
        for (unsigned k = 0; k < DAQ9_ANALOG_CHANNELS; k++) {
            counts[k] = (int16_t)c[k];
        }
        uint8_t frame[DAQ9_FRAME_BYTES];
        if (board_status) {
            daq9_board board;
            daq9_config config = {"HOST", DAQ9_REFERENCE_RANGE_V, DAQ9_REFERENCE_HALL_HIGH_V,
                                  DAQ9_REFERENCE_BAUD, DAQ9_REFERENCE_TIMER_CLOCK_HZ};
            daq9_board_init(&board, &config);
            board.next_counter = (uint32_t)counter;
            daq9_board_take_sample(&board, counts, x != 0u, frame);
        } else {
            daq9_encode_frame(frame, (uint32_t)counter, counts, (uint8_t)x);
        }
        print_frame(frame);
    }
    return feof(stdin) ? 0 : 2;
}

int main(int argc, char **argv)
{
    if (argc == 3 && strcmp(argv[1], "crc") == 0) {
        printf("%04x\n", daq9_crc16((const uint8_t *)argv[2], strlen(argv[2])));
        return 0;
    }
    if (argc == 2 && strcmp(argv[1], "encode") == 0) {
        return frames_from_records(false);
    }
    if (argc == 2 && strcmp(argv[1], "sample") == 0) {
        return frames_from_records(true);
    }
    if (argc >= 2 && strcmp(argv[1], "serve") == 0) {
        const char *serial_number = "HOST0001";
        uint32_t first_counter = 0u;
        int i = 2;
        for (; i + 1 < argc; i += 2) {
            if (strcmp(argv[i], "--serial") == 0) {
                serial_number = argv[i + 1];
            } else if (strcmp(argv[i], "--first-counter") == 0) {
                first_counter = (uint32_t)strtoul(argv[i + 1], NULL, 0);
            } else {
                break;
            }
        }
        if (i == argc) {
            return serve(serial_number, first_counter);
        }
    }
    fprintf(stderr, "usage: %s crc TEXT | encode | sample | serve [--serial TEXT] "
                    "[--first-counter N]\n", argv[0]);
    return 2;
}
