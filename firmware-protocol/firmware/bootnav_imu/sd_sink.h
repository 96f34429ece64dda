/* Binds the bn_sd_sink_t interface (sdlog.h) to a card. With BOOTNAV_SD_LOG=1 this uses the Arduino SD
 * library (FAT16/FAT32, file BN000.TXT, BN001.TXT, ... the first name not yet taken); with 0 there is
 * no card driver and bn_sd_begin() reports "SD absent, not compiled in". */
#ifndef BOOTNAV_SD_SINK_H
#define BOOTNAV_SD_SINK_H

#include <stdint.h>

#include "sdlog.h"

#define BN_SD_DETAIL_NOT_BUILT 0
#define BN_SD_DETAIL_INIT_FAILED 1
#define BN_SD_DETAIL_OPEN_FAILED 2
#define BN_SD_OK 0xFF

/* Start the card and open a new log file. Returns BN_SD_OK and fills *sink, or a BN_SD_DETAIL_* code
 * (reported as status BN_STATUS_SD_ABSENT with that detail). */
uint8_t bn_sd_begin(uint8_t cs_pin, bn_sd_sink_t *sink);

#endif
