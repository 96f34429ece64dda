/* MPU6050 over I2C (Arduino Wire). Registers from the InvenSense MPU-6000/6050 Register Map rev 4.2. */
#ifndef BOOTNAV_MPU6050_H
#define BOOTNAV_MPU6050_H

#include <stdint.h>

#include "frame.h"

#define MPU_REG_SMPLRT_DIV 0x19
#define MPU_REG_CONFIG 0x1A
#define MPU_REG_GYRO_CONFIG 0x1B
#define MPU_REG_ACCEL_CONFIG 0x1C
#define MPU_REG_INT_PIN_CFG 0x37
#define MPU_REG_INT_ENABLE 0x38
#define MPU_REG_INT_STATUS 0x3A
#define MPU_REG_ACCEL_XOUT_H 0x3B
#define MPU_REG_PWR_MGMT_1 0x6B
#define MPU_REG_WHO_AM_I 0x75
#define MPU_REG_FIFO_EN 0x23
#define MPU_REG_USER_CTRL 0x6A
#define MPU_REG_FIFO_COUNTH 0x72
#define MPU_REG_FIFO_R_W 0x74
#define MPU_WHO_AM_I_VALUE 0x68
#define MPU_SAMPLE_BYTES 14
#define MPU_FIFO_BYTES 1024

typedef struct {
    uint8_t addr;
    uint8_t accel_fs;   /* AFS_SEL */
    uint8_t gyro_fs;    /* FS_SEL */
    uint8_t dlpf;       /* DLPF_CFG */
    uint8_t smplrt_div; /* SMPLRT_DIV */
} mpu_config_t;

/* Check WHO_AM_I, reset, wake (PLL on the X gyro), set DLPF, divider and ranges, verify by read-back.
 * The data-ready interrupt stays off (see mpu_enable_data_ready). Returns 0 on success, otherwise a
 * BN_STATUS_* code with *detail = WHO_AM_I read (sensor missing) or the Wire error code. */
uint8_t mpu_begin(const mpu_config_t *cfg, uint8_t *detail);

/* INT pin active high, push-pull, 50 us pulse per new sample; DATA_RDY_EN. Returns a Wire error code. */
uint8_t mpu_enable_data_ready(const mpu_config_t *cfg);

/* Burst-read ACCEL_XOUT_H..GYRO_ZOUT_L (14 bytes, one consistent sample) into s->acc/temp/gyro.
 * Returns 0 or a Wire error code (1..4, 6 = short read). */
uint8_t mpu_read_sample(const mpu_config_t *cfg, bn_sample_t *s);

/* FIFO (1024 bytes = 73 samples of 14 bytes): mpu_fifo_stop selects accel+temp+gyro and empties and
 * disables it; mpu_fifo_start enables writing (one entry per sample from then on). */
uint8_t mpu_fifo_stop(const mpu_config_t *cfg);
uint8_t mpu_fifo_start(const mpu_config_t *cfg);
uint8_t mpu_fifo_count(const mpu_config_t *cfg, uint16_t *count); /* bytes in the FIFO */
uint8_t mpu_fifo_read_sample(const mpu_config_t *cfg, bn_sample_t *s); /* oldest 14 bytes */

#endif
