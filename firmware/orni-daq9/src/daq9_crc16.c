/*
 * CRC-16/CCITT-FALSE, four bits per step: a 16-entry table (32 bytes of flash) is a fair trade on a
 * microcontroller between the bitwise loop (8 steps per byte) and a 512-byte byte-wise table.
 */
#include "daq9_crc16.h"

/* CRC register after clocking the 4-bit value n (in the top nibble) through polynomial 0x1021. */
static const uint16_t nibble_table[16] = {
    0x0000, 0x1021, 0x2042, 0x3063, 0x4084, 0x50A5, 0x60C6, 0x70E7,
    0x8108, 0x9129, 0xA14A, 0xB16B, 0xC18C, 0xD1AD, 0xE1CE, 0xF1EF,
};

uint16_t daq9_crc16(const uint8_t *data, size_t length)
{
    uint16_t crc = DAQ9_CRC16_INITIAL;
    for (size_t i = 0; i < length; i++) {
        crc = (uint16_t)((crc << 4) ^ nibble_table[(crc >> 12) ^ (data[i] >> 4)]);
        crc = (uint16_t)((crc << 4) ^ nibble_table[(crc >> 12) ^ (data[i] & 0x0Fu)]);
    }
    return crc;
}
