/* Compile-time configuration of the bootnav boot sensor. Override any value with -D on the compiler
 * command line (Makefile: `make -C firmware-protocol CONFIG="-DBOOTNAV_ACCEL_FS=2"`), or edit here when
 * building in the Arduino IDE. */
#ifndef BOOTNAV_CONFIG_H
#define BOOTNAV_CONFIG_H

#define BOOTNAV_FW_MAJOR 0
#define BOOTNAV_FW_MINOR 1
#define BOOTNAV_FW_PATCH 0

/* MPU6050 full scale. Foot impacts reach ~5 g while walking and more when running or jumping, and the
 * swing phase turns fast, so the defaults are the widest ranges (seed-004 R4). */
#ifndef BOOTNAV_ACCEL_FS
#define BOOTNAV_ACCEL_FS 3 /* AFS_SEL 0..3 = +-2/4/8/16 g */
#endif
#ifndef BOOTNAV_GYRO_FS
#define BOOTNAV_GYRO_FS 3 /* FS_SEL 0..3 = +-250/500/1000/2000 deg/s */
#endif
/* DLPF_CFG 3: accel 44 Hz / gyro 42 Hz bandwidth, internal rate 1 kHz; below Nyquist of 200 Hz. */
#ifndef BOOTNAV_DLPF
#define BOOTNAV_DLPF 3
#endif
/* rate = 1000 Hz / (1 + SMPLRT_DIV) with DLPF 1..6 (8000 Hz base with DLPF 0 or 7): 4 -> 200 Hz. */
#ifndef BOOTNAV_SMPLRT_DIV
#define BOOTNAV_SMPLRT_DIV 4
#endif

/* Serial: 500000 baud is exact on a 16 MHz AVR (U2X, UBRR 3, 0 % error; 115200 is off by 2.1 %) and
 * is supported by the Nano's CH340 / FT232 USB bridges. A sample frame is 26 bytes = 260 bit times, so
 * 500000 baud carries up to ~1900 frames/s; 200 Hz uses 10.4 % of the line. */
#ifndef BOOTNAV_BAUD
#define BOOTNAV_BAUD 500000UL
#endif

#ifndef BOOTNAV_MPU_ADDR
#define BOOTNAV_MPU_ADDR 0x68 /* 0x69 when AD0 is tied high */
#endif
#ifndef BOOTNAV_I2C_HZ
#define BOOTNAV_I2C_HZ 400000UL /* MPU6050 fast mode: a 14-byte burst takes ~0.45 ms */
#endif
#define BOOTNAV_INT_PIN 2 /* MPU6050 INT -> D2 = INT0 */

/* SD-card text log on SPI (CS D10). Needs the Arduino SD library, which Debian does not package: the
 * Makefile builds with 0 unless SD_LIB=<path to SD/src> is given; the IDE / arduino-cli build uses 1. */
#ifndef BOOTNAV_SD_LOG
#define BOOTNAV_SD_LOG 1
#endif
#ifndef BOOTNAV_SD_CS_PIN
#define BOOTNAV_SD_CS_PIN 10
#endif

/* Data-ready silence after which the sensor is re-initialised: 100 periods at 200 Hz, and longer than
 * the slowest period the MPU6050 can be set to (256 ms). */
#ifndef BOOTNAV_SILENCE_MS
#define BOOTNAV_SILENCE_MS 500u
#endif

/* Read samples from the MPU6050's FIFO (1) or its data registers (0). The FIFO bridges main-loop stalls
 * (SD block writes) of up to ~56 periods with no loss; the register path loses every sample but the
 * newest during a stall (reported as overrun). */
#ifndef BOOTNAV_USE_FIFO
#define BOOTNAV_USE_FIFO 1
#endif
/* Data-ready timestamps queued for FIFO samples (power of 2, 4 bytes each): 64 = 320 ms at 200 Hz.
 * The FIFO itself holds 73 samples; the firmware re-synchronises 8 entries before either runs out. */
#ifndef BOOTNAV_FIFO_QUEUE
#define BOOTNAV_FIFO_QUEUE 64u
#endif
#if (BOOTNAV_FIFO_QUEUE & (BOOTNAV_FIFO_QUEUE - 1u)) != 0 || BOOTNAV_FIFO_QUEUE < 16u
#error "BOOTNAV_FIFO_QUEUE must be a power of 2, at least 16"
#endif

#ifndef BOOTNAV_HEADER_EVERY
#define BOOTNAV_HEADER_EVERY 1000u /* sample frames between header frames (PROTOCOL.md 1.2) */
#endif

/* Derived rate and a compile-time check that the serial line carries it with >= 25 % headroom (header
 * and status frames, USB latency). */
#if (BOOTNAV_DLPF >= 1) && (BOOTNAV_DLPF <= 6)
#define BOOTNAV_RATE_HZ (1000UL / (1UL + BOOTNAV_SMPLRT_DIV))
#else
#define BOOTNAV_RATE_HZ (8000UL / (1UL + BOOTNAV_SMPLRT_DIV))
#endif
#define BOOTNAV_PERIOD_US (1000000UL / BOOTNAV_RATE_HZ)
#if (BOOTNAV_RATE_HZ * 260UL * 5UL) > (BOOTNAV_BAUD * 4UL)
#error "BOOTNAV_BAUD is too low for the configured sample rate (26-byte frames, 10 bits per byte)"
#endif

#endif
