#include "daq9_board.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#define CHANNEL_LIST                                                                               \
    "gauge_0_v,gauge_1_v,gauge_2_v,gauge_3_v,gauge_4_v,gauge_5_v,hotwire_bridge_v,thermocouple_v," \
    "hall_v"
#define MAX_WORDS 3u /* a valid command has at most two words; a third proves the line invalid */

typedef struct {
    const char *start[MAX_WORDS];
    size_t length[MAX_WORDS];
    size_t count; /* words found, at most MAX_WORDS */
} words;

static bool is_blank(char c)
{
    return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f';
}

static words split_words(const char *line, size_t length)
{
    words found = {{0}, {0}, 0};
    size_t i = 0;
    while (i < length && found.count < MAX_WORDS) {
        while (i < length && is_blank(line[i])) {
            i++;
        }
        if (i == length) {
            break;
        }
        found.start[found.count] = &line[i];
        size_t begin = i;
        while (i < length && !is_blank(line[i])) {
            i++;
        }
        found.length[found.count] = i - begin;
        found.count++;
    }
    return found;
}

/* True if the word equals `keyword` (upper case) regardless of the word's case. */
static bool word_is(const words *found, size_t index, const char *keyword)
{
    size_t i = 0;
    for (; i < found->length[index]; i++) {
        char c = found->start[index][i];
        char upper = (c >= 'a' && c <= 'z') ? (char)(c - 'a' + 'A') : c;
        if (keyword[i] == '\0' || upper != keyword[i]) {
            return false;
        }
    }
    return keyword[i] == '\0';
}

void daq9_format_exact(double value, char *text, size_t capacity)
{
    for (int decimals = 1; decimals <= 24; decimals++) {
        snprintf(text, capacity, "%.*f", decimals, value);
        if (strtod(text, NULL) == value) {
            return;
        }
    }
    snprintf(text, capacity, "%.17g", value);
}

double daq9_link_ceiling_hz(uint32_t baud)
{
    return (double)baud / (double)DAQ9_BITS_PER_FRAME_ON_WIRE;
}

double daq9_volts_per_count(double range_v)
{
    return range_v / 32768.0;
}

static double planned_rate(double timer_clock_hz, uint32_t divider, uint32_t period)
{
    return timer_clock_hz / ((double)divider * (double)period);
}

bool daq9_plan_rate(double rate_hz, double timer_clock_hz, double ceiling_hz, daq9_rate_plan *plan)
{
    if (!(rate_hz > 0.0) || !(timer_clock_hz > 0.0) || !isfinite(rate_hz)) {
        return false;
    }
    double ticks = timer_clock_hz / rate_hz;
    double divider = ceil(ticks / (double)DAQ9_TIMER_MAX_PERIOD);
    if (divider < 1.0) {
        divider = 1.0;
    }
    if (divider > (double)DAQ9_TIMER_MAX_DIVIDER) {
        return false;
    }
    double period = round(ticks / divider);
    if (period < 1.0) {
        period = 1.0;
    }
    plan->divider = (uint32_t)divider;
    plan->period = (uint32_t)period;
    /* rounding may land a hair above the link ceiling: take the next longer period then */
    while (planned_rate(timer_clock_hz, plan->divider, plan->period) > ceiling_hz) {
        if (plan->period == DAQ9_TIMER_MAX_PERIOD) {
            return false;
        }
        plan->period++;
    }
    plan->rate_hz = planned_rate(timer_clock_hz, plan->divider, plan->period);
    return true;
}

void daq9_board_init(daq9_board *board, const daq9_config *config)
{
    board->config = *config;
    board->streaming = false;
    board->next_counter = 0u;
    board->line_length = 0u;
    board->line_cut = false;
    daq9_plan_rate(DAQ9_DEFAULT_RATE_HZ, config->timer_clock_hz, daq9_link_ceiling_hz(config->baud),
                   &board->rate);
}

bool daq9_board_feed(daq9_board *board, uint8_t byte)
{
    if (byte == '\n') {
        board->line[board->line_length] = '\0';
        return true;
    }
    if (board->line_length < DAQ9_LINE_CAPACITY) {
        board->line[board->line_length++] = (char)byte;
    } else {
        board->line_cut = true;
    }
    return false;
}

static void reply_identity(const daq9_board *board, char *reply, size_t capacity)
{
    char volts_per_count[48], range_v[48], hall_high_v[48], max_rate_hz[48];
    daq9_format_exact(daq9_volts_per_count(board->config.range_v), volts_per_count,
                      sizeof volts_per_count);
    daq9_format_exact(board->config.range_v, range_v, sizeof range_v);
    daq9_format_exact(board->config.hall_high_v, hall_high_v, sizeof hall_high_v);
    daq9_format_exact(daq9_link_ceiling_hz(board->config.baud), max_rate_hz, sizeof max_rate_hz);
    const char *v = volts_per_count;
    snprintf(reply, capacity,
             "ID model=" DAQ9_MODEL " serial=%s firmware=" DAQ9_FIRMWARE_VERSION
             " channels=" CHANNEL_LIST " volts_per_count=%s,%s,%s,%s,%s,%s,%s,%s range_v=%s"
             " hall_high_v=%s baud=%lu max_rate_hz=%s",
             board->config.serial_number, v, v, v, v, v, v, v, v, range_v, hall_high_v,
             (unsigned long)board->config.baud, max_rate_hz);
}

/* "ERR unknown command '<line>'": the line without its surrounding blanks, bytes outside printable
 * ASCII and the backslash escaped (\xNN, \\), "..." after a line cut at DAQ9_LINE_CAPACITY. */
static void reply_unknown(const daq9_board *board, char *reply, size_t capacity)
{
    size_t begin = 0, end = board->line_length;
    while (begin < end && is_blank(board->line[begin])) {
        begin++;
    }
    while (end > begin && is_blank(board->line[end - 1u])) {
        end--;
    }
    int written = snprintf(reply, capacity, "ERR unknown command '");
    for (size_t i = begin; i < end && written > 0 && (size_t)written < capacity; i++) {
        unsigned char c = (unsigned char)board->line[i];
        size_t room = capacity - (size_t)written;
        if (c == '\\') {
            written += snprintf(reply + written, room, "\\\\");
        } else if (c < 0x20u || c > 0x7Eu) {
            written += snprintf(reply + written, room, "\\x%02x", c);
        } else {
            written += snprintf(reply + written, room, "%c", c);
        }
    }
    if (written > 0 && (size_t)written < capacity) {
        snprintf(reply + written, capacity - (size_t)written, "%s'", board->line_cut ? "..." : "");
    }
}

static void set_rate(daq9_board *board, const words *found, char *reply, size_t capacity)
{
    char text[DAQ9_LINE_CAPACITY + 1u];
    snprintf(text, sizeof text, "%.*s", (int)found->length[1], found->start[1]);
    char *end = NULL;
    double rate_hz = strtod(text, &end);
    if (end == text || *end != '\0') {
        snprintf(reply, capacity, "ERR rate '%s' is not a number", text);
        return;
    }
    double ceiling_hz = daq9_link_ceiling_hz(board->config.baud);
    if (!(DAQ9_MIN_RATE_HZ <= rate_hz && rate_hz <= ceiling_hz)) {
        snprintf(reply, capacity, "ERR rate %g outside %g..%g Hz", rate_hz, DAQ9_MIN_RATE_HZ,
                 ceiling_hz);
        return;
    }
    daq9_rate_plan plan;
    if (!daq9_plan_rate(rate_hz, board->config.timer_clock_hz, ceiling_hz, &plan)) {
        snprintf(reply, capacity, "ERR rate %g cannot be made by the sample timer", rate_hz);
        return;
    }
    board->rate = plan;
    snprintf(reply, capacity, "OK");
}

daq9_action daq9_board_handle_line(daq9_board *board, char *reply, size_t reply_capacity)
{
    words found = split_words(board->line, board->line_length);
    daq9_action action = DAQ9_ACTION_REPLY;
    bool is_stop = found.count == 1u && !board->line_cut && word_is(&found, 0, "STOP");
    if (found.count == 0u && !board->line_cut) {
        action = DAQ9_ACTION_NONE;
    } else if (board->streaming && !is_stop) {
        action = DAQ9_ACTION_NONE; /* while streaming only STOP is heard */
    } else if (board->line_cut) {
        reply_unknown(board, reply, reply_capacity);
    } else if (is_stop) {
        action = board->streaming ? DAQ9_ACTION_STOP : DAQ9_ACTION_REPLY;
        board->streaming = false;
        snprintf(reply, reply_capacity, "OK STOPPED");
    } else if (found.count == 1u && word_is(&found, 0, "ID?")) {
        reply_identity(board, reply, reply_capacity);
    } else if (found.count == 1u && word_is(&found, 0, "RATE?")) {
        snprintf(reply, reply_capacity, "RATE %g", board->rate.rate_hz);
    } else if (found.count == 2u && word_is(&found, 0, "RATE")) {
        set_rate(board, &found, reply, reply_capacity);
    } else if (found.count == 1u && word_is(&found, 0, "START")) {
        action = DAQ9_ACTION_START;
        board->streaming = true;
        snprintf(reply, reply_capacity, "OK");
    } else {
        reply_unknown(board, reply, reply_capacity);
    }
    board->line_length = 0u;
    board->line_cut = false;
    return action;
}

void daq9_board_take_sample(daq9_board *board, const int16_t counts[DAQ9_ANALOG_CHANNELS],
                            bool hall_high, uint8_t frame[DAQ9_FRAME_BYTES])
{
    daq9_encode_frame(frame, board->next_counter, counts, daq9_status(counts, hall_high));
    board->next_counter++; /* unsigned: wraps from 2^32 - 1 to 0 */
}
