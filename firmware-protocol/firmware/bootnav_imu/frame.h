/* bootnav protocol v1 frames (PROTOCOL.md section 1) and SD-card text lines (section 2).
 * Plain C99 without libc formatting, so the same code runs on the ATmega328P and in the host tests.
 * All multi-byte fields are little-endian; they are written byte by byte so the code does not
 * depend on the CPU's byte order or on struct padding. */
#ifndef BOOTNAV_FRAME_H
#define BOOTNAV_FRAME_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define BN_SYNC0 0xA5u
#define BN_SYNC1 0x5Au
#define BN_VERSION 1u

#define BN_TYPE_SAMPLE 0x01u
#define BN_TYPE_HEADER 0x02u
#define BN_TYPE_STATUS 0x03u

#define BN_SAMPLE_LEN 26u
#define BN_HEADER_LEN 24u
#define BN_STATUS_LEN 16u
#define BN_MAX_FRAME_LEN 26u

/* Status / error codes (PROTOCOL.md 1.3). */
#define BN_STATUS_SENSOR_MISSING 1u /* detail = WHO_AM_I read (0xFF: no I2C answer) */
#define BN_STATUS_SD_ABSENT 2u      /* detail: 0 no SD support in this build, 1 card init failed, 2 file open failed */
#define BN_STATUS_SD_FULL 3u        /* detail: 1 write short/failed; value = lines lost */
#define BN_STATUS_OVERRUN 4u        /* detail 0: value = data-ready pulses missed between two reads;
                                       detail 1: no data-ready for BOOTNAV_SILENCE_MS, sensor re-initialised,
                                       value = how often this happened */
#define BN_OVERRUN_DETAIL_MISSED 0u
#define BN_OVERRUN_DETAIL_SILENT 1u
#define BN_STATUS_I2C_ERROR 5u      /* detail = Wire error code; value = error count */

/* Header flags (PROTOCOL.md 1.2). */
#define BN_FLAG_SD_ACTIVE 0x01u
#define BN_FLAG_SERIAL_ACTIVE 0x02u

typedef struct {
    uint16_t seq;
    uint32_t t_us;
    int16_t acc[3];
    int16_t gyro[3];
    int16_t temp;
} bn_sample_t;

typedef struct {
    uint16_t seq; /* seq of the next sample frame */
    uint32_t t_us;
    uint8_t accel_fs;
    uint8_t gyro_fs;
    uint8_t dlpf;
    uint8_t smplrt_div;
    uint8_t fw_version[3];
    uint8_t flags;
    uint32_t device_id;
} bn_header_t;

typedef struct {
    uint16_t seq; /* seq of the next sample frame */
    uint32_t t_us;
    uint8_t code;
    uint8_t detail;
    uint16_t value;
} bn_status_t;

typedef struct {
    uint8_t type; /* BN_TYPE_* */
    union {
        bn_sample_t sample;
        bn_header_t header;
        bn_status_t status;
    } u;
} bn_frame_t;

/* Pack into out (at least BN_*_LEN bytes); return the frame length. */
size_t bn_pack_sample(uint8_t *out, const bn_sample_t *s);
size_t bn_pack_header(uint8_t *out, const bn_header_t *h);
size_t bn_pack_status(uint8_t *out, const bn_status_t *st);

/* Length of a frame of this type, 0 if the type is unknown. */
size_t bn_frame_len(uint8_t type);

/* Result codes of bn_parse (negative: the bytes at buf are not a valid frame). */
#define BN_PARSE_NEED_MORE 0
#define BN_PARSE_BAD_SYNC (-1)
#define BN_PARSE_BAD_TYPE (-2) /* unknown type or version */
#define BN_PARSE_BAD_CRC (-3)

/* Decode the frame that starts at buf[0]. Returns its length (> 0) on success, BN_PARSE_NEED_MORE if
 * len is too short to decide, or a negative BN_PARSE_* code. A receiver that gets a negative code
 * skips one byte and searches for the next sync word. */
int bn_parse(const uint8_t *buf, size_t len, bn_frame_t *out);

/* SD-card text (PROTOCOL.md section 2). Longest data line: 10+5+7*6 digits/signs, 8 commas,
 * '*', 4 hex digits, LF = 71 characters. */
#define BN_SD_LINE_MAX 72u
#define BN_SD_HEADER_MAX 112u

/* Write "t_us,seq,ax,ay,az,gx,gy,gz,temp*CRC\n" into out (cap >= BN_SD_LINE_MAX); return its length
 * (no NUL is written). */
size_t bn_format_sd_line(char *out, const bn_sample_t *s);

/* Write "# bootnav-sd v1 accel_fs=.. gyro_fs=.. dlpf=.. smplrt_div=.. fw=a.b.c device_id=0x........\n"
 * into out (cap >= BN_SD_HEADER_MAX); return its length (no NUL). */
size_t bn_format_sd_header(char *out, const bn_header_t *h);

#ifdef __cplusplus
}
#endif

#endif
