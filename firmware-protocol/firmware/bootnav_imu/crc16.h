/* CRC-16/CCITT-FALSE (PROTOCOL.md section 1): poly 0x1021, init 0xFFFF, no reflection, no final XOR.
 * Check value: "123456789" -> 0x29B1. Plain C99: builds for the AVR and for the host unit tests. */
#ifndef BOOTNAV_CRC16_H
#define BOOTNAV_CRC16_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define BN_CRC16_INIT 0xFFFFu

/* Feed one byte into a running CRC (start with BN_CRC16_INIT). */
uint16_t bn_crc16_update(uint16_t crc, uint8_t byte);

/* CRC of a whole buffer. */
uint16_t bn_crc16(const uint8_t *data, size_t len);

#ifdef __cplusplus
}
#endif

#endif
