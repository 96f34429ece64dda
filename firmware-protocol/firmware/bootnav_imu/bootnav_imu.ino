/* bootnav boot sensor: Arduino Nano (ATmega328P) + MPU6050 (+ optional SD card).
 *
 * The MPU6050 paces everything: its data-ready pulse on INT -> D2 (INT0) timestamps each sample with
 * micros() in the interrupt, and loop() reads the sample (14 bytes), sends a 26-byte sample frame
 * (PROTOCOL.md 1.1) and appends a text line to the SD log. No delay() in the sampling path, so the rate
 * is the sensor's and never drifts with the code's run time. With BOOTNAV_USE_FIFO (default) the
 * samples come from the sensor's 1 KB FIFO, paired one to one with the queued interrupt timestamps, so
 * a main loop stalled by a slow SD write loses nothing for up to ~60 sample periods. Header frames go out at start-up, every
 * BOOTNAV_HEADER_EVERY sample frames and when the host sends 'H'; status frames report a missing
 * sensor, an absent or full card, I2C errors and missed samples. Configuration: config.h. */
#include <Arduino.h>
#include <Wire.h>
#include <avr/eeprom.h>

#include "config.h"
#include "frame.h"
#include "mpu6050.h"
#include "sd_sink.h"
#include "sdlog.h"

static const mpu_config_t g_mpu = {BOOTNAV_MPU_ADDR, BOOTNAV_ACCEL_FS, BOOTNAV_GYRO_FS, BOOTNAV_DLPF,
                                   BOOTNAV_SMPLRT_DIV};

/* Data-ready timestamps, written by the interrupt: a queue of TS_RING (power of 2) for the FIFO
 * path, only the newest for the register path. */
#if BOOTNAV_USE_FIFO
#define TS_RING BOOTNAV_FIFO_QUEUE
#else
#define TS_RING 1u
#endif
static volatile uint16_t g_drdy_count;
static volatile uint32_t g_ts[TS_RING];

static uint16_t g_drdy_handled;  /* data-ready pulses whose sample was sent or given up */
static uint8_t g_fifo_on;        /* FIFO entries pair 1:1 with pulses counted after g_drdy_handled */
static uint16_t g_seq;           /* next sample frame's seq */
static uint16_t g_since_header;  /* sample frames since the last periodic header */
static uint8_t g_flags;          /* BN_FLAG_* */
static uint8_t g_sensor_ok;
static uint32_t g_retry_ms;      /* next sensor retry while it is missing */
static uint32_t g_last_sample_ms; /* millis() of the last sample read (or of the sensor start) */
static uint16_t g_silences;      /* times the data-ready pulses stopped */
static uint16_t g_i2c_errors;
static uint32_t g_device_id;
static bn_sdlog_t g_sdlog;

static void on_data_ready()
{
    uint16_t n = g_drdy_count;
    g_ts[n & (TS_RING - 1u)] = micros();
    g_drdy_count = (uint16_t)(n + 1u);
}

static void send_header()
{
    bn_header_t h;
    h.seq = g_seq;
    h.t_us = micros();
    h.accel_fs = BOOTNAV_ACCEL_FS;
    h.gyro_fs = BOOTNAV_GYRO_FS;
    h.dlpf = BOOTNAV_DLPF;
    h.smplrt_div = BOOTNAV_SMPLRT_DIV;
    h.fw_version[0] = BOOTNAV_FW_MAJOR;
    h.fw_version[1] = BOOTNAV_FW_MINOR;
    h.fw_version[2] = BOOTNAV_FW_PATCH;
    h.flags = g_flags;
    h.device_id = g_device_id;
    uint8_t buf[BN_HEADER_LEN];
    Serial.write(buf, bn_pack_header(buf, &h));
}

static void send_status(uint8_t code, uint8_t detail, uint16_t value)
{
    bn_status_t st;
    st.seq = g_seq;
    st.t_us = micros();
    st.code = code;
    st.detail = detail;
    st.value = value;
    uint8_t buf[BN_STATUS_LEN];
    Serial.write(buf, bn_pack_status(buf, &st));
}

/* Configure the sensor and arm the interrupt before the sensor starts pulsing, so that the first
 * data-ready pulse is already counted. Returns 1 when sampling runs. */
static uint8_t start_sensor()
{
    uint8_t detail;
    uint8_t code = mpu_begin(&g_mpu, &detail);
    if (code == 0) {
        g_fifo_on = 0;
        noInterrupts();
        g_drdy_handled = g_drdy_count;
        interrupts();
        uint8_t err = 0;
#if BOOTNAV_USE_FIFO
        err = mpu_fifo_stop(&g_mpu); /* started in step with the first pulse, see read_registers */
#endif
        if (err == 0)
            err = mpu_enable_data_ready(&g_mpu);
        if (err == 0) {
            g_last_sample_ms = millis();
            return 1;
        }
        code = BN_STATUS_I2C_ERROR;
        detail = err;
    }
    if (code == BN_STATUS_I2C_ERROR)
        g_i2c_errors++;
    send_status(code, detail, code == BN_STATUS_I2C_ERROR ? g_i2c_errors : 0);
    return 0;
}

static void start_sd()
{
#if BOOTNAV_SD_LOG
    bn_sd_sink_t sink;
    uint8_t r = bn_sd_begin(BOOTNAV_SD_CS_PIN, &sink);
    if (r == BN_SD_OK) {
        bn_sdlog_init(&g_sdlog, &sink);
        bn_header_t h = {0, 0, BOOTNAV_ACCEL_FS, BOOTNAV_GYRO_FS, BOOTNAV_DLPF, BOOTNAV_SMPLRT_DIV,
                         {BOOTNAV_FW_MAJOR, BOOTNAV_FW_MINOR, BOOTNAV_FW_PATCH}, 0, g_device_id};
        char line[BN_SD_HEADER_MAX];
        bn_sdlog_append(&g_sdlog, line, (uint16_t)bn_format_sd_header(line, &h));
        g_flags |= BN_FLAG_SD_ACTIVE;
        return;
    }
    send_status(BN_STATUS_SD_ABSENT, r, 0);
#else
    /* Tell the host that this build cannot log to a card (the Debian build: no SD library). */
    send_status(BN_STATUS_SD_ABSENT, BN_SD_DETAIL_NOT_BUILT, 0);
#endif
}

static void log_to_sd(const bn_sample_t *s)
{
    if (!(g_flags & BN_FLAG_SD_ACTIVE))
        return;
    char line[BN_SD_LINE_MAX];
    if (bn_sdlog_append(&g_sdlog, line, (uint16_t)bn_format_sd_line(line, s))) {
        g_flags &= (uint8_t)~BN_FLAG_SD_ACTIVE;
        send_status(BN_STATUS_SD_FULL, 1, g_sdlog.lost);
    }
}

static void report_lost(uint16_t n)
{
    if (n) /* samples that were measured but never sent */
        send_status(BN_STATUS_OVERRUN, BN_OVERRUN_DETAIL_MISSED, n);
}

static void emit_sample(bn_sample_t *s, uint32_t t_us)
{
    g_last_sample_ms = millis();
    s->seq = g_seq++;
    s->t_us = t_us;
    uint8_t buf[BN_SAMPLE_LEN];
    Serial.write(buf, bn_pack_sample(buf, s));
    log_to_sd(s);
    if (++g_since_header >= BOOTNAV_HEADER_EVERY) {
        g_since_header = 0;
        send_header();
    }
#ifdef BOOTNAV_TEST_STALL_AT
    /* Test builds only: stall the loop as a slow SD-card write would. */
    if (s->seq == BOOTNAV_TEST_STALL_AT)
        delay(BOOTNAV_TEST_STALL_MS);
#endif
}

/* The newest sample from the data registers; the register map holds only one, so pulses beyond the
 * newest are lost. With the FIFO this is the synchronisation step: the FIFO is started right after a
 * fresh pulse, so its first entry belongs to the next pulse. */
static void read_registers(uint16_t pending, uint32_t t_newest)
{
    report_lost((uint16_t)(pending - 1u));
#if BOOTNAV_USE_FIFO
    /* Fresh = less than a quarter period old: no other pulse can come before the FIFO runs. */
    if (pending == 1 && (uint32_t)(micros() - t_newest) < BOOTNAV_PERIOD_US / 4u) {
        uint8_t err = mpu_fifo_start(&g_mpu);
        if (err)
            send_status(BN_STATUS_I2C_ERROR, err, ++g_i2c_errors);
        else
            g_fifo_on = 1;
    }
#endif
    bn_sample_t s;
    uint8_t err = mpu_read_sample(&g_mpu, &s);
    if (err) {
        send_status(BN_STATUS_I2C_ERROR, err, ++g_i2c_errors);
        return;
    }
    emit_sample(&s, t_newest);
}

#if BOOTNAV_USE_FIFO
/* Give up the queued samples, empty and stop the FIFO; the next pulse re-synchronises. */
static void resync_fifo(uint16_t lost)
{
    report_lost(lost);
    g_fifo_on = 0;
    mpu_fifo_stop(&g_mpu); /* a failure shows again at the next attempt */
    noInterrupts();
    g_drdy_handled = g_drdy_count;
    interrupts();
}

static void read_fifo(uint16_t pending)
{
    uint16_t bytes;
    uint8_t err = mpu_fifo_count(&g_mpu, &bytes);
    if (err) {
        send_status(BN_STATUS_I2C_ERROR, err, ++g_i2c_errors);
        resync_fifo(pending);
        return;
    }
    /* Near the end of the timestamp queue or of the FIFO (which then overwrites its oldest bytes and
     * loses the 14-byte alignment): start over rather than pair a sample with the wrong time. */
    if (pending > TS_RING - 8u || bytes > MPU_FIFO_BYTES - 2u * MPU_SAMPLE_BYTES) {
        resync_fifo(pending);
        return;
    }
    uint16_t n = bytes / MPU_SAMPLE_BYTES;
    if (n > pending)
        n = pending; /* an entry whose pulse is still being counted: next time */
    for (uint16_t i = 0; i < n; i++) {
        bn_sample_t s;
        err = mpu_fifo_read_sample(&g_mpu, &s);
        if (err) {
            send_status(BN_STATUS_I2C_ERROR, err, ++g_i2c_errors);
            resync_fifo((uint16_t)(pending - i));
            return;
        }
        /* The interrupt writes slot g_drdy_count, never this one while fewer than TS_RING wait. */
        uint32_t t_us = g_ts[g_drdy_handled & (TS_RING - 1u)];
        g_drdy_handled++;
        emit_sample(&s, t_us);
    }
}
#endif

static void handle_sample()
{
    noInterrupts();
    uint16_t count = g_drdy_count;
    uint32_t t_newest = g_ts[(uint16_t)(count - 1u) & (TS_RING - 1u)];
    interrupts();
    uint16_t pending = (uint16_t)(count - g_drdy_handled);
    if (pending == 0)
        return;
#if BOOTNAV_USE_FIFO
    if (g_fifo_on) {
        read_fifo(pending);
        return;
    }
#endif
    g_drdy_handled = count;
    read_registers(pending, t_newest);
}

void setup()
{
    Serial.begin(BOOTNAV_BAUD);
    g_device_id = eeprom_read_dword((const uint32_t *)0); /* board id, 0xFFFFFFFF if never set */
    g_flags = BN_FLAG_SERIAL_ACTIVE;
    Wire.begin();
    Wire.setClock(BOOTNAV_I2C_HZ);
    pinMode(BOOTNAV_INT_PIN, INPUT);
    attachInterrupt(digitalPinToInterrupt(BOOTNAV_INT_PIN), on_data_ready, RISING);
    start_sd();
    send_header();
    g_sensor_ok = start_sensor();
    g_retry_ms = millis() + 1000;
}

void loop()
{
    while (Serial.available() > 0) {
        if (Serial.read() == 'H')
            send_header();
    }
    if (g_sensor_ok) {
        handle_sample();
        if (millis() - g_last_sample_ms > BOOTNAV_SILENCE_MS) {
            /* No data-ready for 0.5 s: the sensor lost power and reset (a boot impact on a loose
             * connector), the INT wire broke, or the sensor is gone. Say so, then re-initialise: that
             * recovers a reset sensor and reports a missing one (status 1). */
            send_status(BN_STATUS_OVERRUN, BN_OVERRUN_DETAIL_SILENT, ++g_silences);
            g_sensor_ok = start_sensor();
            g_retry_ms = millis() + 1000;
        }
    } else if ((int32_t)(millis() - g_retry_ms) >= 0) {
        /* A loose connector: keep reporting and retrying once per second. */
        g_retry_ms += 1000;
        g_sensor_ok = start_sensor();
    }
}
