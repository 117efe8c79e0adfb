/*
 * CRC-16/CCITT-FALSE of the ORNI-DAQ9 frames (docs/daq-protocol.md): polynomial 0x1021, initial
 * value 0xFFFF, no reflection, no final XOR. Check value: the CRC of the nine ASCII bytes
 * "123456789" is 0x29B1. Portable C, no hardware headers.
 */
#ifndef DAQ9_CRC16_H
#define DAQ9_CRC16_H

#include <stddef.h>
#include <stdint.h>

#define DAQ9_CRC16_INITIAL 0xFFFFu
#define DAQ9_CRC16_CHECK 0x29B1u /* CRC of "123456789" */

/* CRC-16/CCITT-FALSE of `length` bytes at `data`. */
uint16_t daq9_crc16(const uint8_t *data, size_t length);

#endif
