"""CRC-16/CCITT-FALSE: the checksum of every protocol-v1 frame and SD-card text line.

Parameters (Rocksoft model, "CRC RevEng" catalogue name CRC-16/IBM-3740, alias CCITT-FALSE):
width 16, poly 0x1021, init 0xFFFF, refin/refout false, xorout 0x0000, check 0x29B1 for
ASCII ``123456789``. Table-driven, one table lookup per byte:

    crc = (crc << 8) ^ T[(crc >> 8) ^ byte]        (all values mod 2**16)

The firmware (firmware-protocol/firmware/) uses the same table, so both sides agree bit for bit. One frame:
the standard library's ``binascii.crc_hqx`` (C; the same CRC with init 0xFFFF). Many equal-length rows:
``crc16_ccitt_false_rows``, one numpy table lookup per byte column, kept because it is faster on arrays —
1 M frames on a 2-core box: 22-byte protocol frames 0.19 s (rows) vs 0.38 s (``crc_hqx`` per frame),
45-byte SD lines 0.40 s vs 0.60 s.
"""

from __future__ import annotations

import binascii

import numpy as np

POLY = 0x1021
INIT = 0xFFFF
CHECK_VALUE = 0x29B1  # crc16_ccitt_false(b"123456789")


def _make_table() -> np.ndarray:
    table = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ POLY) if crc & 0x8000 else (crc << 1)
        table.append(crc & 0xFFFF)
    return np.array(table, dtype=np.uint16)


_TABLE_NP = _make_table()


def crc16_ccitt_false(data: bytes, init: int = INIT) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (bytes-like). Pass a previous result as ``init`` to continue."""
    return binascii.crc_hqx(bytes(data), init & 0xFFFF)


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
