"""Column roles and units: from a header line, a profile or ``--columns``.

Roles: ``t`` (time), ``ax ay az`` (accelerometer), ``gx gy gz`` (gyroscope), ``temp``, ``aux:<name>``
(kept in ``/aux`` of the recording, e.g. magnetometer, heading, FSR, valid flags) and ``-`` (ignored).

Header names are matched case-insensitively. Units in the header win over defaults:
``(g)``, ``(m/s^2)``, ``_mps2``, ``(deg/s)``, ``dps``, ``(rad/s)``, ``_radps``, ``(ms)``, ``(us)``.
"""

from __future__ import annotations

import re

SENSOR_ROLES = ("ax", "ay", "az", "gx", "gy", "gz")
ACC_UNITS = ("g", "mps2", "counts")
GYRO_UNITS = ("dps", "radps", "counts")
TIME_UNITS = ("s", "ms", "us")

_AXIS = r"[ _\-:.]?\(?([xyz])\)?"
_PATTERNS = [
    # (regex on the lower-cased header without its unit suffix, role template, quantity)
    (re.compile(r"^(t|t_s|t_ms|t_us|time|timestamp|time_s|time_ms|time_us|seconds_elapsed|elapsed.*|sec|millis|micros)$"), "t", None),
    (re.compile(r"^(?:.*:)?(?:linear[ _]?acc(?:eleration)?|lin_?acc)" + _AXIS + r"$"), "aux:linacc_{}", "linear"),
    (re.compile(r"^(?:.*:)?(?:estcompensatedaccel|scaledaccel|accelerometer|acceleration|accel|acc|a)" + _AXIS + r"$"), "a{}", "acc"),
    (re.compile(r"^gf([xyz])$"), "a{}", "acc_g"),  # Physics Toolbox g-force meter
    (re.compile(r"^(?:.*:)?(?:estangularrate|scaledgyro|gyroscope|gyro|gyr|angular[ _]?velocity|rate|w|g)" + _AXIS + r"$"), "g{}", "gyro"),
    (re.compile(r"^(?:.*:)?(?:scaledmag|magnetometer|magnetic[ _]field|mag|b)" + _AXIS + r"$"), "aux:mag_{}", "mag"),
    (re.compile(r"^(temp|temperature|t_degc)$"), "temp", None),
]
_UNIT_PATTERNS = [
    (re.compile(r"(\(g\)|_g$|\[g\])"), "g"),
    (re.compile(r"(m/s\^?2|m/s²|mps2|m/s/s|ms\^-2|m s-2)"), "mps2"),
    (re.compile(r"(rad/s|radps|rad s-1)"), "radps"),
    (re.compile(r"(deg/s|°/s|dps|degps|deg s-1)"), "dps"),
    (re.compile(r"(\(ms\)|_ms$|\[ms\])"), "ms"),
    (re.compile(r"(\(us\)|_us$|\(µs\)|\[us\])"), "us"),
    (re.compile(r"(\(s\)|_s$|\[s\])"), "s"),
    (re.compile(r"(counts|lsb|raw)"), "counts"),
]


def _strip_unit(name: str) -> str:
    n = name.strip().lower()
    n = re.sub(r"\s*[\(\[].*?[\)\]]\s*$", "", n)  # "Accelerometer X (g)" -> "accelerometer x"
    n = re.sub(r"_(mps2|radps|dps|g|s|ms|us|degc)$", "", n)  # "ax_mps2" -> "ax"
    return n.strip()


def unit_of(name: str) -> str | None:
    low = name.strip().lower()
    for rx, unit in _UNIT_PATTERNS:
        if rx.search(low):
            return unit
    return None


def role_of(name: str) -> tuple[str | None, str | None]:
    """(role, quantity) of a header name, or (None, None) when unknown."""
    base = _strip_unit(name)
    if not base:
        return None, None
    if base.endswith(":valid"):
        return "aux:" + re.sub(r"[^a-z0-9]+", "_", base.split(":")[-2]) + "_valid", None
    for rx, template, quantity in _PATTERNS:
        m = rx.match(base)
        if m:
            return (template.format(m.group(1)) if "{}" in template else template), quantity
    return None, None


def map_header(header: list[str]) -> tuple[list[str], dict[str, str], dict[str, str]]:
    """Roles for each header column (unknown -> ``aux:<name>``), units found, quantities found.

    The first column matching a sensor role wins; later duplicates become aux columns.
    """
    roles: list[str] = []
    units: dict[str, str] = {}
    quantities: dict[str, str] = {}
    seen: set[str] = set()
    for name in header:
        role, quantity = role_of(name)
        if role is None or role in seen:
            short = _strip_unit(name).split(":")[-1]  # drop device prefixes such as "inertial-6253.76535:"
            role = "aux:" + (re.sub(r"[^a-z0-9]+", "_", short).strip("_") or f"col{len(roles)}")
            if role in seen:
                role = f"{role}_{len(roles)}"
        seen.add(role)
        roles.append(role)
        unit = unit_of(name)
        if unit:
            units[role] = unit
        if quantity:
            quantities[role] = quantity
    return roles, units, quantities


def parse_columns_option(spec: str | list[str], header: list[str] | None, n_fields: int) -> list[str]:
    """``--columns``: either roles in file order (``t,gx,gy,gz,ax,ay,az``, ``-`` skips a column) or
    ``role=NAME_OR_INDEX`` pairs (``t=Time (s),ax=3``; index 0-based)."""
    items = [s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec)]
    if not any("=" in s for s in items):
        roles = [("-" if s in ("", "_") else s) for s in items]
        roles += ["-"] * (n_fields - len(roles))
        return [r if (r in SENSOR_ROLES or r in ("t", "temp", "-") or r.startswith("aux:")) else _bad_role(r)
                for r in roles[:n_fields]]
    roles = ["-"] * n_fields
    for item in items:
        role, _, ref = item.partition("=")
        role, ref = role.strip(), ref.strip()
        if ref.isdigit():
            idx = int(ref)
        elif header and ref in header:
            idx = header.index(ref)
        else:
            raise ValueError(f"--columns: column {ref!r} not found (header: {header})")
        if idx >= n_fields:
            raise ValueError(f"--columns: index {idx} but the file has {n_fields} columns")
        roles[idx] = role if role in SENSOR_ROLES or role in ("t", "temp") or role.startswith("aux:") else _bad_role(role)
    return roles


def _bad_role(role: str):
    raise ValueError(f"--columns: unknown role {role!r} (use t, ax, ay, az, gx, gy, gz, temp, aux:NAME or -)")
