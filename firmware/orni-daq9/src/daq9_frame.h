/*
 * The 25-byte ORNI-DAQ9 sample frame (docs/daq-protocol.md, little-endian): offset 0 sync A5 5A,
 * 2 uint32 counter, 6..21 eight int16 ADC counts, 22 status, 23 CRC of bytes 2..22 (low byte
 * first).
 * Status bit 0: Hall line high; bit 1: over-range (a channel read -32768 or +32767 counts).
 * Portable C, no hardware headers.
 */
#ifndef DAQ9_FRAME_H
#define DAQ9_FRAME_H

#include <stdbool.h>
#include <stdint.h>

#define DAQ9_FRAME_BYTES 25u
#define DAQ9_ANALOG_CHANNELS 8u
#define DAQ9_SYNC_0 0xA5u
#define DAQ9_SYNC_1 0x5Au
#define DAQ9_STATUS_HALL 0x01u
#define DAQ9_STATUS_OVERRANGE 0x02u
#define DAQ9_COUNT_MIN (-32768)
#define DAQ9_COUNT_MAX 32767

/* Write one frame to `frame`; the CRC covers bytes 2..22. */
void daq9_encode_frame(uint8_t frame[DAQ9_FRAME_BYTES], uint32_t counter,
                       const int16_t counts[DAQ9_ANALOG_CHANNELS], uint8_t status);

/* Status byte of a sample: the Hall bit, and the over-range bit when any channel is at either limit
 * (an ADC clips an input beyond its range to the limit code, so the two cannot be told apart). */
uint8_t daq9_status(const int16_t counts[DAQ9_ANALOG_CHANNELS], bool hall_high);

/* Signed counts of an offset-binary ADC code (0x0000 = -full scale, 0x8000 = 0 V, 0xFFFF = +full
 * scale - 1 LSB), the output format of the ADS8688 in its bipolar ranges. */
int16_t daq9_counts_from_offset_binary(uint16_t code);

#endif
