/* bootnav boot sensor: Arduino Nano (ATmega328P) + MPU6050 (+ optional SD card).
 *
 * The MPU6050 paces everything: its data-ready pulse on INT -> D2 (INT0) timestamps each sample with
 * micros() in the interrupt, and loop() reads the 14 data bytes, sends a 26-byte sample frame
 * (PROTOCOL.md 1.1) and appends a text line to the SD log. No delay() in the sampling path, so the rate
 * is the sensor's and never drifts with the code's run time. Header frames go out at start-up, every
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

/* Written by the data-ready interrupt. */
static volatile uint16_t g_drdy_count;
static volatile uint32_t g_drdy_t_us;

static uint16_t g_drdy_handled;  /* g_drdy_count value already processed */
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
    g_drdy_t_us = micros();
    g_drdy_count++;
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
        noInterrupts();
        g_drdy_handled = g_drdy_count;
        interrupts();
        uint8_t err = mpu_enable_data_ready(&g_mpu);
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

static void handle_sample()
{
    noInterrupts();
    uint16_t pending = (uint16_t)(g_drdy_count - g_drdy_handled);
    uint32_t t_us = g_drdy_t_us;
    g_drdy_handled = g_drdy_count;
    interrupts();
    if (pending == 0)
        return;
    if (pending > 1) /* the data registers hold only the newest sample: the others are gone */
        send_status(BN_STATUS_OVERRUN, BN_OVERRUN_DETAIL_MISSED, (uint16_t)(pending - 1));

    bn_sample_t s;
    uint8_t err = mpu_read_sample(&g_mpu, &s);
    if (err) {
        send_status(BN_STATUS_I2C_ERROR, err, ++g_i2c_errors);
        return;
    }
    g_last_sample_ms = millis();
    s.seq = g_seq++;
    s.t_us = t_us;
    uint8_t buf[BN_SAMPLE_LEN];
    Serial.write(buf, bn_pack_sample(buf, &s));
    log_to_sd(&s);
    if (++g_since_header >= BOOTNAV_HEADER_EVERY) {
        g_since_header = 0;
        send_header();
    }
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
