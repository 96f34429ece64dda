"""CRC-16/CCITT-FALSE: the checksum of every protocol-v1 frame and SD-card text line.

Parameters (Rocksoft model, "CRC RevEng" catalogue name CRC-16/IBM-3740, alias CCITT-FALSE):
width 16, poly 0x1021, init 0xFFFF, refin/refout false, xorout 0x0000, check 0x29B1 for
ASCII ``123456789``. Table-driven, one table lookup per byte:

    crc = (crc << 8) ^ T[(crc >> 8) ^ byte]        (all values mod 2**16)

The same table is used by the firmware (firmware-protocol/firmware/), so both sides agree bit for bit.
``crc16_ccitt_false_rows`` computes the CRC of many equal-length rows at once with numpy (one
vectorised table lookup per byte column), which is what makes batch frame validation cheap.
"""

from __future__ import annotations

import numpy as np

POLY = 0x1021
INIT = 0xFFFF
CHECK_VALUE = 0x29B1  # crc16_ccitt_false(b"123456789")


def _make_table() -> tuple[int, ...]:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ POLY) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return tuple(table)


CRC16_TABLE: tuple[int, ...] = _make_table()
_TABLE_NP = np.array(CRC16_TABLE, dtype=np.uint16)


def crc16_ccitt_false(data: bytes, init: int = INIT) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (bytes-like). Pass a previous result as ``init`` to continue."""
    crc = init & 0xFFFF
    table = CRC16_TABLE
    for byte in bytes(data):
        crc = ((crc << 8) & 0xFFFF) ^ table[(crc >> 8) ^ byte]
    return crc


def crc16_ccitt_false_rows(rows: np.ndarray, init: int = INIT) -> np.ndarray:
    """CRC of every row of a 2-D uint8 array (n_rows, n_bytes) -> uint16 array (n_rows,)."""
    rows = np.asarray(rows, dtype=np.uint8)
    if rows.ndim != 2:
        raise ValueError(f"rows must be 2-D (n_rows, n_bytes), got shape {rows.shape}")
    crc = np.full(rows.shape[0], init & 0xFFFF, dtype=np.uint16)
    for col in range(rows.shape[1]):
        idx = (crc >> 8) ^ rows[:, col]
        crc = (crc << 8) ^ _TABLE_NP[idx]
    return crc


assert crc16_ccitt_false(b"123456789") == CHECK_VALUE
