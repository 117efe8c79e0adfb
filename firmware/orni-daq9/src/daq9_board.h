/*
 * The ORNI-DAQ9 board's behaviour apart from its hardware: command lines and their replies, the
 * sample rate (validated against the link ceiling and rounded to whole periods of the sample
 * timer), the streaming state and the sample counter. Portable C, no hardware headers: the same
 * code runs on the RP2040 (target/rp2040_main.c) and in the host harness the tests drive
 * (host/daq9_host.c).
 *
 * Commands (docs/daq-protocol.md): "ID?", "RATE <hz>", "RATE?", "START", "STOP"; one reply line
 * each. While streaming only STOP is heard. Keywords are matched without regard to case and words
 * may be separated by any blanks, as the Python simulator does; an empty line is ignored.
 */
#ifndef DAQ9_BOARD_H
#define DAQ9_BOARD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "daq9_frame.h"

#define DAQ9_MODEL "ORNI-DAQ9"
#define DAQ9_FIRMWARE_VERSION "1.0.0"
#define DAQ9_MIN_RATE_HZ 100.0
#define DAQ9_DEFAULT_RATE_HZ 10000.0
#define DAQ9_BITS_PER_FRAME_ON_WIRE 250u /* 25 bytes x 10 bits (8N1) */
#define DAQ9_LINE_CAPACITY 64u          /* longest command line kept, bytes; longer lines are cut */
#define DAQ9_REPLY_CAPACITY 512u        /* room for the longest reply line (ID?), bytes */
#define DAQ9_TIMER_MAX_PERIOD 65536u    /* counts per period of a 16-bit timer */
#define DAQ9_TIMER_MAX_DIVIDER 255u     /* largest integer prescaler of the timer clock */

/* The reference board (README.md): RP2040 at clk_sys 128 MHz clocking its PWM sample timer, UART at
 * 4 Mbaud, ADS8688 in its +-10.24 V range, Hall comparator output at 3.3 V logic. */
#define DAQ9_REFERENCE_TIMER_CLOCK_HZ 128000000.0
#define DAQ9_REFERENCE_BAUD 4000000u
#define DAQ9_REFERENCE_RANGE_V 10.24
#define DAQ9_REFERENCE_HALL_HIGH_V 3.3

/* What never changes while the board runs. */
typedef struct {
    const char *serial_number; /* printable, no blanks */
    double range_v;            /* +- full scale of every analog channel, V (ADS8688: 10.24) */
    double hall_high_v;        /* logic-high level reported for the Hall line, V */
    uint32_t baud;             /* serial line rate, baud; sets the link ceiling baud / 250 */
    double timer_clock_hz;     /* clock of the sample timer before its prescaler, Hz */
} daq9_config;

/* A sample rate as the timer makes it: timer_clock_hz / (divider * period). */
typedef struct {
    uint32_t divider; /* integer prescaler, 1..DAQ9_TIMER_MAX_DIVIDER */
    uint32_t period;  /* prescaled counts per sample, 1..DAQ9_TIMER_MAX_PERIOD */
    double rate_hz;   /* the rate this gives, Hz */
} daq9_rate_plan;

typedef enum {
    DAQ9_ACTION_NONE,  /* nothing to send (empty line, or a command not heard while streaming) */
    DAQ9_ACTION_REPLY, /* send the reply line */
    DAQ9_ACTION_START, /* send the reply line ("OK"), then start the sample clock */
    DAQ9_ACTION_STOP   /* stop the sample clock, send the frames taken, then the reply line */
} daq9_action;

typedef struct {
    daq9_config config;
    daq9_rate_plan rate;
    bool streaming;
    uint32_t next_counter; /* counter of the next sample taken; wraps at 2^32 */
    char line[DAQ9_LINE_CAPACITY + 1u];
    size_t line_length;
    bool line_cut; /* the line was longer than DAQ9_LINE_CAPACITY */
} daq9_board;

/* Power-up state: stopped, counter 0, DAQ9_DEFAULT_RATE_HZ. */
void daq9_board_init(daq9_board *board, const daq9_config *config);

/* Highest frame rate the serial line carries: baud / 250, Hz. */
double daq9_link_ceiling_hz(uint32_t baud);

/* Volts per ADC count of a +-range_v 16-bit channel: range_v / 32768, V. */
double daq9_volts_per_count(double range_v);

/* The timer setting nearest to `rate_hz` (never above `ceiling_hz`); false if none exists. */
bool daq9_plan_rate(double rate_hz, double timer_clock_hz, double ceiling_hz, daq9_rate_plan *plan);

/* Add one received byte to the command line; true when a line ('\n') is complete and waits in
 * board->line for daq9_board_handle_line. */
bool daq9_board_feed(daq9_board *board, uint8_t byte);

/* Act on the complete line and write the reply line (no newline) to `reply`. */
daq9_action daq9_board_handle_line(daq9_board *board, char *reply, size_t reply_capacity);

/* Take one sample: encode it with the next counter and its status byte, advance the counter. */
void daq9_board_take_sample(daq9_board *board, const int16_t counts[DAQ9_ANALOG_CHANNELS],
                            bool hall_high, uint8_t frame[DAQ9_FRAME_BYTES]);

/* Shortest decimal text of `value` that reads back as the same double, always with a decimal
 * point ("16000.0", "0.0003125"), like Python's repr for values from 1e-4 to 1e5 (needs a
 * `capacity` of 32 bytes). */
void daq9_format_exact(double value, char *text, size_t capacity);

#endif
