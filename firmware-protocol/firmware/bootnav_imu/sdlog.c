/* Buffered SD-card logging; see sdlog.h. */
#include "sdlog.h"

#include <string.h>

void bn_sdlog_init(bn_sdlog_t *log, const bn_sd_sink_t *sink)
{
    memset(log, 0, sizeof *log);
    log->sink = *sink;
}

/* Hand the buffer to the sink; on a short write mark the log failed. Returns 1 on a new failure. */
static uint8_t drain(bn_sdlog_t *log)
{
    if (log->used == 0 || log->failed)
        return 0;
    uint16_t want = log->used;
    uint16_t n = log->sink.write(log->sink.ctx, log->buf, want);
    log->used = 0;
    if (n == want)
        return 0;
    log->failed = 1;
    /* every line end that did not reach the card is a lost line */
    for (uint16_t i = n; i < want; i++)
        if (log->buf[i] == '\n' && log->lost != 0xFFFFu)
            log->lost++;
    return 1;
}

uint8_t bn_sdlog_append(bn_sdlog_t *log, const char *line, uint16_t len)
{
    if (log->failed) {
        if (log->lost != 0xFFFFu)
            log->lost++;
        return 0;
    }
    uint8_t newly_failed = 0;
    if (log->used + len > BN_SDLOG_BUF)
        newly_failed = drain(log);
    if (log->failed) {
        if (log->lost != 0xFFFFu)
            log->lost++;
        return newly_failed;
    }
    memcpy(log->buf + log->used, line, len);
    log->used += len;
    if (++log->since_flush >= BN_SDLOG_FLUSH_EVERY)
        newly_failed |= bn_sdlog_flush(log);
    return newly_failed;
}

uint8_t bn_sdlog_flush(bn_sdlog_t *log)
{
    uint8_t newly_failed = drain(log);
    log->since_flush = 0;
    if (!log->failed && !log->sink.flush(log->sink.ctx)) {
        log->failed = 1;
        newly_failed = 1;
    }
    return newly_failed;
}
