"""Reading delimited text tables from other IMUs: sniffing and fast, line-accurate parsing.

The parser never guesses silently and never drops data silently:

* encoding: UTF-8 (BOM removed), UTF-16 (a byte-order mark or every other byte NUL: Windows "Unicode"
  exports), else cp1252; gzip transparently (a cut-off stream keeps its complete lines); other files with NUL
  bytes or mostly control bytes are rejected as binary;
* lines: split on LF, a trailing CR removed (CRLF files), blank lines ignored, comment lines
  (``#``, ``%``, ``//``) collected as the preamble;
* delimiter: ``;``, tab, ``,`` or runs of whitespace, chosen as the one that splits the first data lines
  into the same number (> 1) of fields; a trailing delimiter on every line (``1;2;3;``) is dropped;
* decimal comma: accepted when the delimiter is not a comma (``0,5;1,25``);
* header: the last non-numeric line before the first numeric one, quotes stripped;
* numbers: plain numeric files go through ``bootnav.core.csvio.parse_numeric_lines`` (numpy per chunk of
  lines, line by line only inside a chunk that fails); other files (quotes, date-time text) are split into
  strings and each needed column is converted by numpy in one call; either way the bad lines are returned
  with 1-based line numbers so the caller can record them as ``skipped_line`` events while keeping every
  good line.
"""

from __future__ import annotations

import csv
import gc
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core.csvio import decompress, parse_numeric_lines
from bootnav.errors import InputError

COMMENT_PREFIXES = ("#", "%", "//")
_NUM_RE = re.compile(r"^\s*[-+]?(\d+([.,]\d*)?|[.,]\d+)([eE][-+]?\d+)?\s*$|^\s*[-+]?(nan|inf|NaN|Inf)\s*$")
WHITESPACE = "whitespace"


def read_text(path: Path) -> tuple[str, bytes, str | None]:
    """Return (text, raw bytes, damage) of a text file; binary files are refused.

    gzip is undone; a cut-off or damaged gzip stream keeps what precedes the damage and says what went wrong
    in ``damage`` (None when intact), so the caller can drop the incomplete last line and report it.
    """
    data, raw, damage = read_bytes(path)
    return decode_text(path, data, damage), raw, damage


def read_bytes(path: Path) -> tuple[bytes, bytes, str | None]:
    """(decompressed bytes, file bytes, damage) of a file; see ``read_text``."""
    raw = Path(path).read_bytes()
    data, damage = decompress(raw)
    return data, raw, damage


def utf16_encoding(data: bytes) -> str | None:
    """``utf-16-le``/``utf-16-be`` when ``data`` is UTF-16 text (a byte-order mark, or ASCII text whose every
    other byte is NUL, as Windows "Unicode" exports are), else None."""
    if data[:2] == b"\xff\xfe":
        return "utf-16-le"
    if data[:2] == b"\xfe\xff":
        return "utf-16-be"
    head = np.frombuffer(data[:4096], dtype=np.uint8)
    head = head[: head.size - head.size % 2]
    if head.size < 8:
        return None
    nul_even, nul_odd = float(np.mean(head[0::2] == 0)), float(np.mean(head[1::2] == 0))
    if nul_odd > 0.9 and nul_even < 0.1:
        return "utf-16-le"
    if nul_even > 0.9 and nul_odd < 0.1:
        return "utf-16-be"
    return None


def decode_text(path: Path, data: bytes, damage: str | None = None) -> str:
    """Text of the (decompressed) bytes: UTF-8 (BOM removed), UTF-16 (BOM or NUL pattern), else cp1252;
    refuses a binary file with the offset of its first NUL byte."""
    if not data.strip():
        raise InputError(f"{path}: file is empty (no data lines)")
    utf16 = utf16_encoding(data)
    if utf16:
        body = data[2:] if data[:2] in (b"\xff\xfe", b"\xfe\xff") else data
        text = body[: len(body) - len(body) % 2].decode(utf16, errors="replace")  # a cut last byte dropped
        if not text.strip("\x00\n\r\t \ufeff"):
            raise InputError(f"{path}: file is empty (no data lines)")
        if "\x00" in text:
            raise InputError(f"{path}: file is UTF-16 ({utf16}) with NUL characters (at character "
                             f"{text.index(chr(0))}); save it again as UTF-8 text")
        return text.lstrip("\ufeff")
    head = data[:65536]
    nul = head.find(b"\x00")
    control = sum(head.count(bytes([c])) for c in range(32) if c not in (9, 10, 13))
    if nul >= 0 or control > 0.01 * len(head):
        where = f"first NUL byte at offset {nul}" if nul >= 0 else f"{control} control bytes in the first {len(head)}"
        raise InputError(f"{path}: looks like a binary file, not a text log ({where})")
    data = data[3:] if data[:3] == b"\xef\xbb\xbf" else data  # the UTF-8 byte-order mark, even before bad bytes
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:  # Windows loggers: "°/s" in cp1252/latin-1 headers; a damaged tail: cut anyway
        return data.decode("utf-8", errors="replace") if damage else data.decode("cp1252", errors="replace")


def is_number(token: str) -> bool:
    return bool(_NUM_RE.match(token.strip().strip('"')))


def split_line(line: str, delimiter: str, quoted: bool = False) -> list[str]:
    if delimiter == WHITESPACE:
        return line.split()
    if quoted and '"' in line:  # "0,005","1,25": a delimiter inside quotes is part of the value
        return [f.strip() for f in next(csv.reader([line], delimiter=delimiter, skipinitialspace=True))]
    return line.split(delimiter)


@dataclass
class TextTable:
    """A parsed text table: header names, data cells, 1-based line numbers per row.

    Cells are either ``matrix`` (float64, the fast path: every line well-formed and numeric) or
    ``rows`` (split strings, the careful path that finds the bad lines).
    """

    path: Path
    delimiter: str
    decimal_comma: bool
    header: list[str] | None
    header_line: int  # 1-based, -1 if none
    preamble: list[tuple[int, str]]  # comment / non-data lines before the data (line, text)
    rows: list[list[str]] | None  # split fields of the well-formed data lines (careful path)
    line_numbers: np.ndarray  # (n_rows,) 1-based line numbers of the data rows
    n_fields: int
    bad_lines: list[tuple[int, str]] = field(default_factory=list)  # (line, reason)
    ends_without_newline: bool = False
    n_lines: int = 0
    trailing_delimiter: bool = False
    matrix: np.ndarray | None = None  # (n_rows, n_fields) float64 (fast path)

    @property
    def n_rows(self) -> int:
        return int(self.line_numbers.shape[0])

    def cell(self, row: int, index: int) -> str:
        if self.matrix is not None:
            return repr(float(self.matrix[row, index]))
        return self.rows[row][index]

    def column(self, index: int) -> list[str]:
        if self.matrix is not None:
            return [repr(v) for v in self.matrix[:, index].tolist()]
        return [r[index] for r in self.rows]

    def numeric(self, index: int) -> tuple[np.ndarray, list[int]]:
        """Column ``index`` as float64; returns (values with NaN at bad rows, indices of bad rows)."""
        if self.matrix is not None:
            return self.matrix[:, index].copy(), []
        col = self.column(index)
        if col and col[0].lstrip().startswith('"'):
            col = [c.strip().strip('"') for c in col]
        if self.decimal_comma:
            col = [c.replace(",", ".") for c in col]
        try:
            return np.array(col, dtype=np.float64), []
        except ValueError:
            out = np.empty(len(col))
            bad = []
            for i, c in enumerate(col):
                try:
                    out[i] = float(c.strip().strip('"'))
                except ValueError:
                    out[i] = np.nan
                    bad.append(i)
            return out, bad


def _sniff_delimiter(lines: list[str]) -> str:
    best, best_score = WHITESPACE, -1
    for delim in (";", "\t", ",", WHITESPACE):
        counts = [len(split_line(ln, delim, quoted=True)) for ln in lines]
        if not counts:
            continue
        mode = max(set(counts), key=counts.count)
        agree = counts.count(mode)
        if mode > 1 and agree >= 0.8 * len(counts) and agree > best_score:
            best, best_score = delim, agree
            if delim != WHITESPACE:
                break  # first explicit delimiter that splits consistently wins (";" before ",": decimal comma)
    return best


HEAD_LINES = 200


def parse_table(path: Path, text: str, *, delimiter: str | None = None, header: bool | None = None,
                skip_lines: int = 0) -> TextTable:
    """Split ``text`` into a table. ``delimiter``/``header`` None = auto-detect."""
    ends_without_newline = not text.endswith("\n")
    n_total_lines = text.count("\n") + (1 if ends_without_newline else 0)
    candidates, preamble = _head_lines(text, skip_lines)
    if not candidates:
        raise InputError(f"{path}: no data lines (only blank or comment lines)")

    sample = [ln for _, ln in candidates[:60]]
    delim = delimiter or _sniff_delimiter(sample)
    fields0 = [split_line(ln, delim, quoted=True) for ln in sample]

    def numeric_row(fields: list[str]) -> bool:
        real = [f for f in fields if f.strip() != ""]
        n_num = sum(is_number(f) for f in real)
        return bool(real) and n_num >= max(1, len(real) - 1)  # allow one text column (a date/time)

    first_data = next((k for k, f in enumerate(fields0) if numeric_row(f)), None)
    if first_data is None:
        raise InputError(f"{path}: no numeric data line in the first {len(sample)} lines "
                         f"(first line {candidates[0][0]}: {candidates[0][1][:80]!r})")
    first_line_no = candidates[first_data][0]  # 1-based
    head_data = candidates[first_data:]
    trailing = delim != WHITESPACE and all(ln.rstrip().endswith(delim) for _, ln in head_data[:50])
    quoted = any('"' in ln for _, ln in head_data[:50])
    head_rows = [split_line(ln.rstrip() if trailing else ln, delim, quoted) for _, ln in head_data[:200]]
    if trailing:
        head_rows = [r[:-1] if r and r[-1] == "" else r for r in head_rows]
    lengths = [len(r) for r in head_rows]
    n_fields = max(set(lengths), key=lengths.count)
    # header: the last line before the data with as many fields as the data (``_header_line``)
    hdr, header_line, header_k = None, -1, -1
    if header is not False:
        hdr, header_line, header_k = _header_line(candidates[:first_data], delim, trailing, n_fields)
        if header is True and hdr is None:
            raise InputError(f"{path}: a header line with {n_fields} fields was expected before line {first_line_no}")
    stray: list[tuple[int, str]] = []  # non-data lines between the header and the data: reported, not hidden
    for k, (ln_no, ln) in enumerate(candidates[:first_data]):
        if header_k >= 0 and k > header_k:
            stray.append((ln_no, f"not a data line (between the header and the data): {ln[:60]!r}"))
        elif k != header_k:
            preamble.append((ln_no, ln))
    decimal_comma = False
    if delim != "," or quoted:
        decimal_comma = any(re.match(r"^\s*\"?[-+]?\d+,\d+", f) for r in head_rows[:50] for f in r)
    common = dict(path=Path(path), delimiter=delim, decimal_comma=decimal_comma, header=hdr,
                  header_line=header_line, preamble=preamble, n_fields=n_fields,
                  ends_without_newline=ends_without_newline, n_lines=n_total_lines, trailing_delimiter=trailing)

    lines = text.split("\n", first_line_no - 1)[-1].split("\n")
    if not ends_without_newline:
        lines.pop()
    if not quoted and delim != WHITESPACE:
        parsed = parse_numeric_lines(lines, first_line_no, n_fields, delim, trailing=trailing,
                                     decimal_comma=decimal_comma, comment_prefixes=COMMENT_PREFIXES,
                                     give_up_fraction=0.5)
        if parsed is not None:
            matrix, lines_no, bad = parsed
            return TextTable(rows=None, line_numbers=lines_no, matrix=matrix, bad_lines=stray + list(bad), **common)

    good_rows, good_lines, bad = _careful_rows(lines, first_line_no, delim, quoted, trailing, n_fields)
    return TextTable(rows=good_rows, line_numbers=np.asarray(good_lines, dtype=np.int64), bad_lines=stray + bad,
                     **common)


def _head_lines(text: str, skip_lines: int) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    """(candidates, preamble) of the first ``HEAD_LINES`` lines: the non-blank, non-comment lines (1-based
    line number, text) where the header and the data are looked for, and the skipped / leading comment lines."""
    candidates: list[tuple[int, str]] = []
    preamble: list[tuple[int, str]] = []
    for i, raw_line in enumerate(text.split("\n", HEAD_LINES)[:HEAD_LINES]):
        ln = raw_line.rstrip("\r")
        if i < skip_lines:
            preamble.append((i + 1, ln))
            continue
        s = ln.strip()
        if not s:
            continue
        if s.startswith(COMMENT_PREFIXES):
            if not candidates:
                preamble.append((i + 1, ln))
            continue
        candidates.append((i + 1, ln))
    return candidates, preamble


def _header_line(before_data: list[tuple[int, str]], delim: str, trailing: bool,
                 n_fields: int) -> tuple[list[str] | None, int, int]:
    """The header among the lines before the data: the last one with as many fields as the data (a stray line
    such as "logger started" between header and data is preamble, not the header). Returns (names, line
    number, index in ``before_data``), or (None, -1, -1)."""
    for k in range(len(before_data) - 1, -1, -1):
        fields = [h.strip().strip('"').strip("'").strip() for h in split_line(before_data[k][1], delim, True)]
        if trailing and fields and fields[-1] == "":
            fields = fields[:-1]
        if len(fields) == n_fields:
            return fields, before_data[k][0], k
    return None, -1, -1


def _careful_rows(lines: list[str], first_line_no: int, delim: str, quoted: bool, trailing: bool, n_fields: int):
    """The careful path: line by line, every malformed line reported with its number. Returns (rows of
    field strings, their line numbers, [(line, why)] of the bad ones)."""
    good_rows, good_lines, bad = [], [], []
    gc_was = gc.isenabled()
    gc.disable()  # millions of small lists: the cyclic GC would rescan them again and again
    try:
        for k, raw_line in enumerate(lines):
            ln = raw_line.rstrip("\r")
            s = ln.strip()
            if not s or s.startswith(COMMENT_PREFIXES):
                continue
            r = split_line(s if trailing else ln, delim, quoted)
            if trailing and r and r[-1] == "":
                r.pop()
            if len(r) == n_fields:
                good_rows.append(r)
                good_lines.append(first_line_no + k)
            else:
                bad.append((first_line_no + k, f"{len(r)} fields, expected {n_fields}: {ln[:60]!r}"))
    finally:
        if gc_was:
            gc.enable()
    return good_rows, good_lines, bad
