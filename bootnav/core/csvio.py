"""The canonical IMU CSV (``imu*.csv.gz`` / ``acc.csv.gz``): the one reader, line-accurate and fast.

Format (the dataset tree's and ``bootnav``'s exchange format): a header line
``t_s,ax_mps2,ay_mps2,az_mps2[,gx_radps,gy_radps,gz_radps]`` then one sample per line, SI units, comma
separated, plain text or gzip. Time is the recording's own clock (s), never resampled.

Recovery (nothing silent, nothing invented): a line with the wrong number of fields, a value that is not a
number, or NaN/inf is skipped and reported as ``(line number, reason)``; every intact line is kept. A gzip
stream that is cut off (a copy interrupted, a full disk) or damaged keeps every complete line before the damage
and reports the line where it stops. More than ``max_bad_fraction`` bad lines is an ``InputError`` (the file
is not what its header says).

Speed: the whole block is parsed by numpy in C (``np.fromstring``); only a chunk that fails is re-read line by
line, to name its bad lines.
"""

from __future__ import annotations

import warnings
import zlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from bootnav.core.errors import InputError

TIME_COLUMN = "t_s"
ACC_COLUMNS = ("ax_mps2", "ay_mps2", "az_mps2")
GYRO_COLUMNS = ("gx_radps", "gy_radps", "gz_radps")
IMU_HEADER = (TIME_COLUMN, *ACC_COLUMNS, *GYRO_COLUMNS)
ACC_HEADER = (TIME_COLUMN, *ACC_COLUMNS)
CHUNK_LINES = 20_000  # lines per numpy call when a file has bad lines
_GZIP_BLOCK = 1 << 20  # compressed bytes per decompression step
_GZIP_PIECE = 512  # compressed bytes per step when locating damage


@dataclass
class ImuCsv:
    """A canonical IMU CSV in memory (SI units).

    ``gyro_radps`` is None for an accelerometer-only file. ``bad_lines`` lists the skipped lines as
    (1-based line number, reason); ``line_numbers`` gives the source line of each kept sample.
    """

    t_s: np.ndarray  # (N,) s
    acc_mps2: np.ndarray  # (N, 3)
    gyro_radps: np.ndarray | None  # (N, 3) or None
    bad_lines: list[tuple[int, str]] = field(default_factory=list)
    line_numbers: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))
    header: tuple[str, ...] = IMU_HEADER
    n_lines: int = 0  # lines in the file (header included)


def decompress(raw: bytes) -> tuple[bytes, str | None]:
    """Undo gzip if ``raw`` is gzip (else return it); keep what precedes a cut-off or damaged stream.

    Returns
    -------
    data : bytes
        The decompressed bytes: all of them, or everything before the damage (to within
        ``_GZIP_PIECE`` compressed bytes).
    damage : str or None
        None for an intact stream, else what went wrong ("gzip stream cut off", "damaged gzip data: ...").
    """
    if raw[:2] != b"\x1f\x8b":
        return raw, None
    out: list[bytes] = []
    d = zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)
    pos = 0
    while pos < len(raw):
        block = raw[pos : pos + _GZIP_BLOCK]
        saved = d.copy()
        try:
            out.append(d.decompress(block))
        except zlib.error as exc:  # replay the block in small pieces to keep what precedes the damage
            d = saved
            for k in range(0, len(block), _GZIP_PIECE):
                try:
                    out.append(d.decompress(block[k : k + _GZIP_PIECE]))
                except zlib.error:
                    break
            return b"".join(out), f"damaged gzip data ({exc})"
        pos += len(block)
        if d.eof:
            rest = d.unused_data + raw[pos:]
            if rest[:2] != b"\x1f\x8b":
                break
            raw, pos, d = rest, 0, zlib.decompressobj(wbits=16 + zlib.MAX_WBITS)  # concatenated gzip members
    out.append(d.flush())
    return b"".join(out), None if d.eof else "gzip stream cut off (truncated file)"


def drop_nonfinite_lines(values: np.ndarray, line_numbers: np.ndarray, fields, bad: list):
    """The rows of ``values`` (parsed lines, ``line_numbers``) whose every column is finite; each dropped line is
    appended to ``bad`` as (line number, message naming its first NaN/inf column)."""
    finite = np.isfinite(values).all(axis=1)
    if finite.all():
        return values, line_numbers
    for i in np.flatnonzero(~finite):
        j = int(np.flatnonzero(~np.isfinite(values[i]))[0])
        bad.append((int(line_numbers[i]),
                    f"column {j + 1} ({fields[j]}) is {str(float(values[i, j]))!r} (NaN/inf: line skipped)"))
    return values[finite], line_numbers[finite]


def parse_numeric_lines(lines: list[str], first_line_no: int, n_fields: int, delimiter: str = ",", *,
                        trailing: bool = False, decimal_comma: bool = False, comment_prefixes: tuple[str, ...] = (),
                        give_up_fraction: float | None = None
                        ) -> tuple[np.ndarray, np.ndarray, list[tuple[int, str]]] | None:
    """Delimited numeric lines -> (values (K, n_fields), 1-based line numbers (K,), bad lines).

    Blank lines (and lines starting with one of ``comment_prefixes``) are ignored; a line with another field
    count or a non-number is a bad line, reported as (line number, reason). Each chunk of ``CHUNK_LINES`` lines
    is parsed by numpy in one call; only a chunk that fails is read line by line, to name its bad lines.

    Parameters
    ----------
    lines : list of str
        The lines, without their newline (a trailing CR is removed).
    first_line_no : int
        1-based line number of ``lines[0]``.
    n_fields : int
        Fields per line.
    delimiter : str
        Field separator.
    trailing : bool
        Every line ends with a delimiter (``1;2;3;``), dropped.
    decimal_comma : bool
        ``0,5`` means 0.5 (the delimiter is then not a comma).
    comment_prefixes : tuple of str
        Prefixes of lines to skip silently.
    give_up_fraction : float, optional
        Return None as soon as more than this fraction of the lines read so far is bad (a file that is not
        plain numbers, e.g. with a date-time column, goes to a string-based parser instead).

    Returns
    -------
    tuple or None
        ``(values, line_numbers, bad_lines)``, or None when ``give_up_fraction`` was exceeded.
    """
    blocks, numbers, bad = [], [], []
    for a in range(0, len(lines), CHUNK_LINES):
        chunk = lines[a : a + CHUNK_LINES]
        m = _fast_block(chunk, n_fields, delimiter, trailing, decimal_comma)
        if m is not None:
            blocks.append(m)
            numbers.append(np.arange(first_line_no + a, first_line_no + a + m.shape[0], dtype=np.int64))
            continue
        rows, nums = [], []
        for k, raw_line in enumerate(chunk):
            ln = raw_line.rstrip("\r")
            s = ln.strip()
            if not s or (comment_prefixes and s.startswith(comment_prefixes)):
                continue
            f = (s if trailing else ln).split(delimiter)
            if trailing and f and f[-1] == "":
                f.pop()
            if len(f) != n_fields:
                bad.append((first_line_no + a + k, f"{len(f)} fields, expected {n_fields}: {ln[:60]!r}"))
                continue
            vals = [x.replace(",", ".") for x in f] if decimal_comma else f
            try:
                rows.append([float(x) for x in vals])
            except ValueError:
                j = next(j for j, x in enumerate(vals) if not _is_float(x))
                bad.append((first_line_no + a + k, f"column {j + 1} is not a number: {f[j][:30]!r}"))
                continue
            nums.append(first_line_no + a + k)
        blocks.append(np.array(rows, dtype=np.float64).reshape(-1, n_fields))
        numbers.append(np.asarray(nums, dtype=np.int64))
        if give_up_fraction is not None and len(bad) > give_up_fraction * (a + len(chunk)):
            return None
    if not blocks:
        return np.zeros((0, n_fields)), np.zeros(0, dtype=np.int64), bad
    return np.concatenate(blocks), np.concatenate(numbers), bad


def _is_float(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _fast_block(chunk: list[str], n_fields: int, delimiter: str, trailing: bool, decimal_comma: bool
                ) -> np.ndarray | None:
    """The chunk parsed by numpy in C, or None when any line is irregular (then it is read line by line).

    Accepted only when there are no blank, comment or quoted lines and every line has exactly the expected
    number of delimiters, so each value is known to sit in its own row and column.
    """
    body = "\n".join(chunk)
    if "\r" in body:  # CRLF lines
        body = body.replace("\r\n", "\n")
        if body.endswith("\r"):
            body = body[:-1]
    if not chunk or any(c in body for c in ('"', "#", "%", "/", "\r", "\n\n")) or body.startswith("\n") \
            or body.endswith("\n"):
        return None
    per_line = n_fields if trailing else n_fields - 1
    if body.count(delimiter) != len(chunk) * per_line:
        return None
    if trailing:
        body = body.replace(delimiter + "\n", "\n")
        if body.endswith(delimiter):
            body = body[:-1]
    if decimal_comma:
        body = body.replace(",", ".")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            flat = np.fromstring(body.replace("\n", delimiter), sep=delimiter)
        except ValueError:
            return None
    if flat.size != len(chunk) * n_fields:
        return None
    return flat.reshape(len(chunk), n_fields)


def canonical_header(first_line: str) -> tuple[str, ...] | None:
    """``IMU_HEADER`` or ``ACC_HEADER`` when ``first_line`` is exactly one of them (BOM, CR, spaces allowed)."""
    header = tuple(h.strip() for h in first_line.rstrip("\r").lstrip("\ufeff").split(","))
    return header if header in (IMU_HEADER, ACC_HEADER) else None


def drop_incomplete_tail(text: str, damage: str | None) -> tuple[str, tuple[int, str] | None]:
    """Text of a damaged stream up to its last complete line, and the (line number, reason) of what is lost.

    A line that the damage cut short may still parse (``0.12`` of ``0.1234``), so it is never used. Intact
    text (``damage`` None) is returned as is.
    """
    if damage is None:
        return text, None
    cut = text.rfind("\n") + 1
    n_complete = text.count("\n", 0, cut)
    if cut < len(text):
        return text[:cut], (n_complete + 1, f"{damage}: line incomplete")
    return text, (n_complete + 1, f"{damage}: the file ends after line {n_complete}")


def parse_imu_csv(text: str, path: str | Path, *, max_bad_fraction: float = 0.01,
                  damage: str | None = None) -> ImuCsv:
    """Parse the text of a canonical IMU CSV (see ``read_imu_csv``; ``damage`` from ``decompress``)."""
    text, lost = drop_incomplete_tail(text, damage)
    lines = text.split("\n")
    if text.endswith("\n"):
        lines.pop()
    n_lines = len(lines)
    first = lines[0] if lines else ""
    fields = tuple(h.strip() for h in first.rstrip("\r").lstrip("\ufeff").split(","))
    header = next((h for h in (IMU_HEADER, ACC_HEADER) if fields[: len(h)] == h), None)
    if header is None or header == ACC_HEADER and GYRO_COLUMNS[0] in fields:
        raise InputError(f"{path}: line 1: not a canonical IMU CSV: header {first[:80]!r}, expected "
                         f"{','.join(IMU_HEADER)!r} (or its first four columns for an accelerometer-only file)")
    n_fields = len(fields)
    values, line_numbers, bad = parse_numeric_lines(lines[1:], 2, n_fields)
    values, line_numbers = drop_nonfinite_lines(values, line_numbers, fields, bad)
    bad = sorted(bad) + ([lost] if lost else [])
    n_data = n_lines - 1 + (1 if lost else 0)
    if not bad and values.shape[0] == 0:
        raise InputError(f"{path}: line 2: no data line after the header")
    if len(bad) > max_bad_fraction * n_data:
        raise InputError(f"{path}: {len(bad)} of {n_data} data lines unreadable (line {bad[0][0]}: {bad[0][1]}); "
                         f"expected {n_fields} numbers per line")
    gyro = np.ascontiguousarray(values[:, 4:7]) if header == IMU_HEADER else None
    return ImuCsv(t_s=values[:, 0].copy(), acc_mps2=np.ascontiguousarray(values[:, 1:4]), gyro_radps=gyro,
                  bad_lines=bad, line_numbers=line_numbers, header=header, n_lines=n_lines)


def read_imu_csv(path: str | Path, *, max_bad_fraction: float = 0.01) -> ImuCsv:
    """Read a canonical ``imu*.csv(.gz)`` / ``acc.csv(.gz)`` file.

    Parameters
    ----------
    path : str or Path
        Plain or gzip text; header ``t_s,ax_mps2,ay_mps2,az_mps2[,gx_radps,gy_radps,gz_radps]`` (extra
        columns after these are ignored).
    max_bad_fraction : float
        Largest tolerated fraction of skipped data lines (module docstring).

    Returns
    -------
    ImuCsv
        Times (s, as in the file), specific force (m/s²), angular rate (rad/s) or None, and the skipped
        lines with their reasons.

    Raises
    ------
    InputError
        One line naming the file and the line: missing file, not the canonical header, too many bad lines,
        no data.
    """
    path = Path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    data, damage = decompress(raw)
    return parse_imu_csv(data.decode("utf-8", errors="replace"), path, max_bad_fraction=max_bad_fraction,
                         damage=damage)
