/*
 * ORNI-DAQ9 on an RP2040 (Raspberry Pi Pico) with a TI ADS8688 ADC: the hardware half of the
 * firmware. Built only with the Pico SDK (../CMakeLists.txt); it has not been built for the target
 * or run in this repository (see ../README.md). Everything that decides which bytes go on the line
 * -- frames, CRC, counter, status bits, command replies, rate validation -- is the portable core in
 * ../src, which the tests build on the host and drive with the Python driver.
 *
 * Data path: a PWM slice wraps at the sample rate and interrupts; the interrupt latches the Hall
 * line, reads the eight ADS8688 channels over SPI0, has the core encode the frame and puts it in a
 * frame FIFO. The main loop moves FIFO bytes into UART0 (4 Mbaud, to an FT232H USB-serial bridge)
 * whenever the UART's transmit FIFO has room, and feeds received bytes to the command parser.
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "hardware/clocks.h"
#include "hardware/gpio.h"
#include "hardware/irq.h"
#include "hardware/pwm.h"
#include "hardware/spi.h"
#include "hardware/sync.h"
#include "hardware/uart.h"
#include "pico/stdlib.h"
#include "pico/unique_id.h"

#include "daq9_board.h"
#include "daq9_frame.h"

/* Pin map (README.md) */
#define PIN_LINK_TX 0       /* UART0 TX -> FT232H RXD */
#define PIN_LINK_RX 1       /* UART0 RX <- FT232H TXD */
#define PIN_SAMPLE_CLOCK 14 /* PWM slice 7 A: the sample clock as a square wave (test point) */
#define PIN_ADC_SDO 16      /* SPI0 RX <- ADS8688 SDO */
#define PIN_ADC_CS 17       /* ADS8688 CS, a plain GPIO so one CS low spans a 32-SCLK frame */
#define PIN_ADC_SCLK 18     /* SPI0 SCK -> ADS8688 SCLK */
#define PIN_ADC_SDI 19      /* SPI0 TX -> ADS8688 SDI */
#define PIN_ADC_RST_PD 20   /* ADS8688 RST/PD: low resets / powers down, high runs */
#define PIN_HALL 21         /* comparator output, high when the Hall line is above 1.65 V */
#define PIN_LED 25          /* the Pico's LED, lit while streaming */

#define SYS_CLOCK_HZ ((uint32_t)DAQ9_REFERENCE_TIMER_CLOCK_HZ) /* 128 MHz: 4 Mbaud is divisor 2.0 */
#define ADC_SPI spi0
#define ADC_SCLK_HZ 16000000u /* 128 MHz / 8; check against the ADS8688's SCLK maximum */
#define ADC_POWER_UP_MS 100u  /* generous wait for the internal reference after RST/PD goes high */
#define LINK_UART uart0

/* ADS8688 command words (16 bits, sent MSB first in the first half of a 32-SCLK frame) */
#define ADS_NO_OP 0x0000u
#define ADS_RESET 0x8500u
#define ADS_MANUAL_CHANNEL(channel) ((uint16_t)(0xC000u | ((uint16_t)(channel) << 10)))
/* ADS8688 program registers: channel n input range at 0x05 + n; 0x00 = +-2.5 x VREF (+-10.24 V) */
#define ADS_REGISTER_RANGE(channel) ((uint8_t)(0x05u + (channel)))
#define ADS_RANGE_PLUS_MINUS_2V5_VREF 0x00u

/* Frames taken by the interrupt and not yet sent: 256 frames = 25.6 ms at 10 kHz, 6.4 kB. The
 * indices count frames modulo 2^32; FIFO_FRAMES divides 2^32, so index % FIFO_FRAMES stays valid
 * across the wrap. */
#define FIFO_FRAMES 256u
static uint8_t fifo[FIFO_FRAMES][DAQ9_FRAME_BYTES];
static volatile uint32_t fifo_written; /* frames put by the interrupt */
static volatile uint32_t fifo_sent;    /* frames whose last byte went to the UART */
static uint32_t next_byte;             /* next byte of frame fifo_sent to send */

static daq9_board board;
static uint sample_clock_slice;

/* One 32-SCLK frame: CS falling samples the channel the previous frame selected; `command` selects
 * the next; the conversion result comes back in the second 16 bits. */
static uint16_t adc_frame(uint16_t command)
{
    uint16_t sent[2] = {command, ADS_NO_OP};
    uint16_t received[2];
    gpio_put(PIN_ADC_CS, 0);
    spi_write16_read16_blocking(ADC_SPI, sent, received, 2);
    gpio_put(PIN_ADC_CS, 1);
    return received[1];
}

/* Program-register write: 7-bit address, write bit, 8 data bits (24 SCLK). */
static void adc_write_register(uint8_t address, uint8_t value)
{
    const uint8_t sent[3] = {(uint8_t)((address << 1) | 1u), value, 0u};
    spi_set_format(ADC_SPI, 8, SPI_CPOL_0, SPI_CPHA_1, SPI_MSB_FIRST);
    gpio_put(PIN_ADC_CS, 0);
    spi_write_blocking(ADC_SPI, sent, sizeof sent);
    gpio_put(PIN_ADC_CS, 1);
    spi_set_format(ADC_SPI, 16, SPI_CPOL_0, SPI_CPHA_1, SPI_MSB_FIRST);
}

static void adc_init(void)
{
    spi_init(ADC_SPI, ADC_SCLK_HZ);
    spi_set_format(ADC_SPI, 16, SPI_CPOL_0, SPI_CPHA_1, SPI_MSB_FIRST); /* SPI mode 1 */
    gpio_set_function(PIN_ADC_SDO, GPIO_FUNC_SPI);
    gpio_set_function(PIN_ADC_SCLK, GPIO_FUNC_SPI);
    gpio_set_function(PIN_ADC_SDI, GPIO_FUNC_SPI);
    gpio_init(PIN_ADC_CS);
    gpio_set_dir(PIN_ADC_CS, GPIO_OUT);
    gpio_put(PIN_ADC_CS, 1);
    gpio_init(PIN_ADC_RST_PD);
    gpio_set_dir(PIN_ADC_RST_PD, GPIO_OUT);
    gpio_put(PIN_ADC_RST_PD, 1);
    sleep_ms(ADC_POWER_UP_MS);
    adc_frame(ADS_RESET); /* program registers to their defaults */
    for (uint channel = 0; channel < DAQ9_ANALOG_CHANNELS; channel++) {
        adc_write_register(ADS_REGISTER_RANGE(channel), ADS_RANGE_PLUS_MINUS_2V5_VREF);
    }
}

/* Channel k's frame selects channel k + 1; the last selects channel 0 for the next sample. The
 * ADS8688 multiplexes one converter: channel k is sampled k frames after channel 0 (a frame is a
 * little over 2 us at 16 MHz SCLK). */
static void adc_read_channels(int16_t counts[DAQ9_ANALOG_CHANNELS])
{
    for (uint channel = 0; channel < DAQ9_ANALOG_CHANNELS; channel++) {
        uint16_t code = adc_frame(ADS_MANUAL_CHANNEL((channel + 1u) % DAQ9_ANALOG_CHANNELS));
        counts[channel] = daq9_counts_from_offset_binary(code);
    }
}

static void on_sample_clock(void)
{
    pwm_clear_irq(sample_clock_slice);
    bool hall_high = gpio_get(PIN_HALL); /* latched just before channel 0 is sampled */
    int16_t counts[DAQ9_ANALOG_CHANNELS];
    adc_read_channels(counts);
    uint32_t written = fifo_written;
    if (written - fifo_sent >= FIFO_FRAMES) {
        /* the link has not kept up: the sample keeps its counter, so the host sees the gap */
        board.next_counter++;
        return;
    }
    daq9_board_take_sample(&board, counts, hall_high, fifo[written % FIFO_FRAMES]);
    __dmb(); /* the frame's bytes are in memory before the main loop may see the new index */
    fifo_written = written + 1u;
}

/* Move FIFO bytes into the UART while its transmit FIFO has room; never blocks. */
static void send_pending_bytes(void)
{
    while (fifo_sent != fifo_written && uart_is_writable(LINK_UART)) {
        uart_get_hw(LINK_UART)->dr = fifo[fifo_sent % FIFO_FRAMES][next_byte];
        if (++next_byte == DAQ9_FRAME_BYTES) {
            next_byte = 0;
            fifo_sent = fifo_sent + 1u;
        }
    }
}

static void send_line(const char *text)
{
    uart_write_blocking(LINK_UART, (const uint8_t *)text, strlen(text));
    uart_putc_raw(LINK_UART, '\n');
}

static void start_sample_clock(void)
{
    fifo_written = 0;
    fifo_sent = 0;
    next_byte = 0;
    adc_frame(ADS_MANUAL_CHANNEL(0)); /* the first sample's first frame converts channel 0 */
    pwm_config config = pwm_get_default_config();
    pwm_config_set_clkdiv_int(&config, board.rate.divider);
    pwm_config_set_wrap(&config, (uint16_t)(board.rate.period - 1u));
    pwm_init(sample_clock_slice, &config, false);
    pwm_set_chan_level(sample_clock_slice, PWM_CHAN_A, (uint16_t)(board.rate.period / 2u));
    pwm_clear_irq(sample_clock_slice);
    pwm_set_irq_enabled(sample_clock_slice, true);
    gpio_put(PIN_LED, 1);
    pwm_set_enabled(sample_clock_slice, true);
}

/* Stop the clock, then send every frame already taken (the frame in progress included). */
static void stop_sample_clock(void)
{
    pwm_set_enabled(sample_clock_slice, false);
    pwm_set_irq_enabled(sample_clock_slice, false);
    pwm_clear_irq(sample_clock_slice);
    gpio_put(PIN_LED, 0);
    while (fifo_sent != fifo_written) {
        send_pending_bytes();
    }
}

static void handle_line(void)
{
    static char reply[DAQ9_REPLY_CAPACITY];
    switch (daq9_board_handle_line(&board, reply, sizeof reply)) {
    case DAQ9_ACTION_NONE:
        break;
    case DAQ9_ACTION_REPLY:
        send_line(reply);
        break;
    case DAQ9_ACTION_START:
        send_line(reply); /* "OK\n" enters the UART FIFO before the first frame byte */
        start_sample_clock();
        break;
    case DAQ9_ACTION_STOP:
        stop_sample_clock();
        send_line(reply);
        break;
    }
}

static void link_init(void)
{
    uart_init(LINK_UART, DAQ9_REFERENCE_BAUD); /* 128 MHz / (16 x 4 Mbaud) = 2.0: no baud error */
    uart_set_format(LINK_UART, 8, 1, UART_PARITY_NONE);
    uart_set_hw_flow(LINK_UART, false, false);
    uart_set_fifo_enabled(LINK_UART, true);
    gpio_set_function(PIN_LINK_TX, GPIO_FUNC_UART);
    gpio_set_function(PIN_LINK_RX, GPIO_FUNC_UART);
}

static void sample_clock_init(void)
{
    gpio_set_function(PIN_SAMPLE_CLOCK, GPIO_FUNC_PWM);
    sample_clock_slice = pwm_gpio_to_slice_num(PIN_SAMPLE_CLOCK);
    irq_set_exclusive_handler(PWM_IRQ_WRAP, on_sample_clock);
    irq_set_priority(PWM_IRQ_WRAP, PICO_HIGHEST_IRQ_PRIORITY);
    irq_set_enabled(PWM_IRQ_WRAP, true);
}

int main(void)
{
    set_sys_clock_khz(SYS_CLOCK_HZ / 1000u, true);
    clock_configure(clk_peri, 0, CLOCKS_CLK_PERI_CTRL_AUXSRC_VALUE_CLK_SYS, SYS_CLOCK_HZ,
                    SYS_CLOCK_HZ); /* UART and SPI run from clk_sys */
    gpio_init(PIN_LED);
    gpio_set_dir(PIN_LED, GPIO_OUT);
    gpio_init(PIN_HALL);
    gpio_set_dir(PIN_HALL, GPIO_IN);
    gpio_disable_pulls(PIN_HALL); /* the comparator drives it push-pull */

    static char serial_number[2 * PICO_UNIQUE_BOARD_ID_SIZE_BYTES + 1];
    pico_get_unique_board_id_string(serial_number, sizeof serial_number);
    const daq9_config config = {serial_number, DAQ9_REFERENCE_RANGE_V, DAQ9_REFERENCE_HALL_HIGH_V,
                                DAQ9_REFERENCE_BAUD, DAQ9_REFERENCE_TIMER_CLOCK_HZ};
    daq9_board_init(&board, &config);

    link_init();
    adc_init();
    sample_clock_init();
    for (;;) {
        send_pending_bytes();
        while (uart_is_readable(LINK_UART)) {
            if (daq9_board_feed(&board, (uint8_t)uart_getc(LINK_UART))) {
                handle_line();
            }
        }
    }
}
