#include "daq9_frame.h"

#include "daq9_crc16.h"

void daq9_encode_frame(uint8_t frame[DAQ9_FRAME_BYTES], uint32_t counter,
                       const int16_t counts[DAQ9_ANALOG_CHANNELS], uint8_t status)
{
    frame[0] = DAQ9_SYNC_0;
    frame[1] = DAQ9_SYNC_1;
    for (unsigned byte = 0; byte < 4u; byte++) {
        frame[2u + byte] = (uint8_t)(counter >> (8u * byte));
    }
    for (unsigned channel = 0; channel < DAQ9_ANALOG_CHANNELS; channel++) {
        /* two's complement bit pattern, written low byte first whatever the host's endianness */
        uint16_t bits = (uint16_t)counts[channel];
        frame[6u + 2u * channel] = (uint8_t)(bits & 0xFFu);
        frame[7u + 2u * channel] = (uint8_t)(bits >> 8);
    }
    frame[22] = status;
    uint16_t crc = daq9_crc16(&frame[2], 21u);
    frame[23] = (uint8_t)(crc & 0xFFu);
    frame[24] = (uint8_t)(crc >> 8);
}

uint8_t daq9_status(const int16_t counts[DAQ9_ANALOG_CHANNELS], bool hall_high)
{
    uint8_t status = hall_high ? DAQ9_STATUS_HALL : 0u;
    for (unsigned channel = 0; channel < DAQ9_ANALOG_CHANNELS; channel++) {
        if (counts[channel] == DAQ9_COUNT_MIN || counts[channel] == DAQ9_COUNT_MAX) {
            status |= DAQ9_STATUS_OVERRANGE;
        }
    }
    return status;
}

int16_t daq9_counts_from_offset_binary(uint16_t code)
{
    /* flipping the top bit maps offset binary onto two's complement; the sign is then applied
     * explicitly, so no implementation-defined conversion is involved */
    uint16_t bits = (uint16_t)(code ^ 0x8000u);
    return (bits & 0x8000u) ? (int16_t)(-(int32_t)(0x10000u - bits)) : (int16_t)bits;
}
