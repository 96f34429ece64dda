/* SD-card sink; see sd_sink.h. */
#include "sd_sink.h"

#include "config.h"

#if BOOTNAV_SD_LOG
#include <SD.h>
#include <SPI.h>

static File g_file;

static uint16_t sd_write(void *, const uint8_t *data, uint16_t len)
{
    return (uint16_t)g_file.write(data, len);
}

static uint8_t sd_flush(void *)
{
    g_file.flush();
    return g_file.getWriteError() ? 0 : 1;
}

uint8_t bn_sd_begin(uint8_t cs_pin, bn_sd_sink_t *sink)
{
    if (!SD.begin(cs_pin))
        return BN_SD_DETAIL_INIT_FAILED;
    char name[] = "BN000.TXT";
    for (uint16_t i = 0; i < 1000; i++) {
        name[2] = (char)('0' + i / 100);
        name[3] = (char)('0' + (i / 10) % 10);
        name[4] = (char)('0' + i % 10);
        if (!SD.exists(name))
            break; /* never overwrite an earlier recording */
    }
    if (SD.exists(name))
        return BN_SD_DETAIL_OPEN_FAILED; /* all 1000 names taken */
    g_file = SD.open(name, FILE_WRITE);
    if (!g_file)
        return BN_SD_DETAIL_OPEN_FAILED;
    sink->write = sd_write;
    sink->flush = sd_flush;
    sink->ctx = 0;
    return BN_SD_OK;
}

#else

uint8_t bn_sd_begin(uint8_t, bn_sd_sink_t *)
{
    return BN_SD_DETAIL_NOT_BUILT;
}

#endif
