/* Buffered SD-card text logging behind a small sink interface (PROTOCOL.md section 2).
 *
 * Why an interface: Debian's arduino-core-avr ships no SD library, so the card driver is a
 * pluggable sink. sd_sink.cpp binds it to the Arduino SD library when that library is installed
 * (arduino-cli / IDE route); the host tests bind it to a RAM "card" with a capacity limit.
 *
 * Why a buffer: one text line is ~60 bytes; handing the card driver 128-byte chunks cuts the per-call
 * overhead, and an explicit flush every BN_SDLOG_FLUSH_EVERY lines bounds what a power loss can lose
 * (the driver only updates the file size in the directory entry on flush). Plain C99. */
#ifndef BOOTNAV_SDLOG_H
#define BOOTNAV_SDLOG_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#ifndef BN_SDLOG_BUF
#define BN_SDLOG_BUF 128u
#endif
#ifndef BN_SDLOG_FLUSH_EVERY
#define BN_SDLOG_FLUSH_EVERY 1000u /* lines: 5 s at 200 Hz */
#endif

typedef struct {
    /* Store len bytes; return how many were stored (fewer = card full or write error). */
    uint16_t (*write)(void *ctx, const uint8_t *data, uint16_t len);
    /* Commit what was written (file size, FAT); return 1 on success. */
    uint8_t (*flush)(void *ctx);
    void *ctx;
} bn_sd_sink_t;

typedef struct {
    bn_sd_sink_t sink;
    uint8_t buf[BN_SDLOG_BUF];
    uint16_t used;
    uint8_t failed;        /* sink failed once: stop writing (a full card stays full) */
    uint16_t lost;         /* lines dropped since the failure (saturates at 65535) */
    uint16_t since_flush;  /* lines appended since the last flush */
} bn_sdlog_t;

void bn_sdlog_init(bn_sdlog_t *log, const bn_sd_sink_t *sink);

/* Append one complete line (len <= BN_SDLOG_BUF). Returns 1 if this call detected a NEW sink failure
 * (the caller reports BN_STATUS_SD_FULL once), else 0. After a failure lines are counted in lost. */
uint8_t bn_sdlog_append(bn_sdlog_t *log, const char *line, uint16_t len);

/* Write out the buffer and commit it. Returns 1 on a new failure, else 0. */
uint8_t bn_sdlog_flush(bn_sdlog_t *log);

#ifdef __cplusplus
}
#endif

#endif
