/* MPU6050 set-up and sample read-out; see mpu6050.h. */
#include "mpu6050.h"

#include <Arduino.h>
#include <Wire.h>

#include "frame.h"

static uint8_t write_reg(uint8_t addr, uint8_t reg, uint8_t value)
{
    Wire.beginTransmission(addr);
    Wire.write(reg);
    Wire.write(value);
    return Wire.endTransmission(true);
}

/* Read n bytes starting at reg (repeated start, the register pointer auto-increments). */
static uint8_t read_regs(uint8_t addr, uint8_t reg, uint8_t *out, uint8_t n)
{
    Wire.beginTransmission(addr);
    Wire.write(reg);
    uint8_t err = Wire.endTransmission(false);
    if (err)
        return err;
    if (Wire.requestFrom(addr, n, (uint8_t) true) != n)
        return 6;
    for (uint8_t i = 0; i < n; i++)
        out[i] = (uint8_t)Wire.read();
    return 0;
}

/* Reset, wake and configure; returns 0 or a Wire error code (7 = read-back mismatch). */
static uint8_t configure(const mpu_config_t *cfg)
{
    uint8_t err = write_reg(cfg->addr, MPU_REG_PWR_MGMT_1, 0x80); /* DEVICE_RESET */
    if (err)
        return err;
    delay(100); /* reset time; set-up only, sampling is paced by the sensor */
    /* CLKSEL 1: PLL with the X gyro as reference (datasheet: more stable than the 8 MHz RC oscillator);
     * also clears SLEEP. */
    const uint8_t setup[][2] = {
        {MPU_REG_PWR_MGMT_1, 0x01},
        {MPU_REG_INT_ENABLE, 0x00},
        {MPU_REG_SMPLRT_DIV, cfg->smplrt_div},
        {MPU_REG_CONFIG, (uint8_t)(cfg->dlpf & 0x07)},
        {MPU_REG_GYRO_CONFIG, (uint8_t)((cfg->gyro_fs & 0x03) << 3)},
        {MPU_REG_ACCEL_CONFIG, (uint8_t)((cfg->accel_fs & 0x03) << 3)},
    };
    for (uint8_t i = 0; i < sizeof setup / sizeof setup[0]; i++) {
        err = write_reg(cfg->addr, setup[i][0], setup[i][1]);
        if (err)
            return err;
    }
    /* Read back SMPLRT_DIV..ACCEL_CONFIG: a write the sensor did not take would silently change the
     * scale factors of the whole recording. */
    uint8_t back[4];
    err = read_regs(cfg->addr, MPU_REG_SMPLRT_DIV, back, 4);
    if (err)
        return err;
    for (uint8_t i = 0; i < 4; i++)
        if (back[i] != setup[2 + i][1])
            return 7;
    return 0;
}

uint8_t mpu_begin(const mpu_config_t *cfg, uint8_t *detail)
{
    uint8_t who = 0xFF;
    if (read_regs(cfg->addr, MPU_REG_WHO_AM_I, &who, 1) != 0 || who != MPU_WHO_AM_I_VALUE) {
        *detail = who; /* 0xFF: nobody answered at this address */
        return BN_STATUS_SENSOR_MISSING;
    }
    *detail = configure(cfg);
    return *detail ? BN_STATUS_I2C_ERROR : 0;
}

uint8_t mpu_enable_data_ready(const mpu_config_t *cfg)
{
    /* INT_PIN_CFG 0: active high, push-pull, 50 us pulse (no latch, so nothing to clear per sample). */
    uint8_t err = write_reg(cfg->addr, MPU_REG_INT_PIN_CFG, 0x00);
    if (err)
        return err;
    return write_reg(cfg->addr, MPU_REG_INT_ENABLE, 0x01); /* DATA_RDY_EN */
}

/* 14 big-endian bytes ACCEL X,Y,Z, TEMP, GYRO X,Y,Z (data registers and FIFO alike) -> sample. */
static void decode14(const uint8_t *b, bn_sample_t *s)
{
    for (uint8_t i = 0; i < 3; i++) {
        s->acc[i] = (int16_t)(((uint16_t)b[2 * i] << 8) | b[2 * i + 1]);
        s->gyro[i] = (int16_t)(((uint16_t)b[8 + 2 * i] << 8) | b[9 + 2 * i]);
    }
    s->temp = (int16_t)(((uint16_t)b[6] << 8) | b[7]);
}

uint8_t mpu_read_sample(const mpu_config_t *cfg, bn_sample_t *s)
{
    uint8_t b[MPU_SAMPLE_BYTES];
    uint8_t err = read_regs(cfg->addr, MPU_REG_ACCEL_XOUT_H, b, MPU_SAMPLE_BYTES);
    if (err)
        return err;
    decode14(b, s);
    return 0;
}

uint8_t mpu_fifo_stop(const mpu_config_t *cfg)
{
    /* FIFO_EN: temp, gyro X/Y/Z, accel -> 14 bytes per sample in register order, like a burst read. */
    uint8_t err = write_reg(cfg->addr, MPU_REG_FIFO_EN, 0xF8);
    if (err)
        return err;
    return write_reg(cfg->addr, MPU_REG_USER_CTRL, 0x04); /* FIFO off, FIFO_RESET */
}

uint8_t mpu_fifo_start(const mpu_config_t *cfg)
{
    return write_reg(cfg->addr, MPU_REG_USER_CTRL, 0x40); /* FIFO_EN */
}

uint8_t mpu_fifo_count(const mpu_config_t *cfg, uint16_t *count)
{
    uint8_t b[2];
    uint8_t err = read_regs(cfg->addr, MPU_REG_FIFO_COUNTH, b, 2);
    if (err)
        return err;
    *count = (uint16_t)(((uint16_t)b[0] << 8) | b[1]);
    return 0;
}

uint8_t mpu_fifo_read_sample(const mpu_config_t *cfg, bn_sample_t *s)
{
    uint8_t b[MPU_SAMPLE_BYTES];
    uint8_t err = read_regs(cfg->addr, MPU_REG_FIFO_R_W, b, MPU_SAMPLE_BYTES); /* FIFO_R_W does not advance */
    if (err)
        return err;
    decode14(b, s);
    return 0;
}
