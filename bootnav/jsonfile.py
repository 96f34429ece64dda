"""Read a user's JSON file (settings, calibration) with an error that names the file and the spot."""

from __future__ import annotations

import json
from pathlib import Path

from bootnav.errors import InputError


def read_json_file(path: str | Path, what: str):
    """Parsed JSON of ``path``; ``InputError`` "PATH: WHAT not found" or "PATH: invalid JSON at line L column C"."""
    path = Path(path)
    try:
        return json.loads(path.read_text())
    except FileNotFoundError:
        raise InputError(f"{path}: {what} not found") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{path}: invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}") from None
