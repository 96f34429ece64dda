"""``recording.RecordingReader`` is the one decoder of the ``/imu`` layout: its blocks are exactly what
``recording.load`` returns, for every chunking, and no other module decodes the layout itself."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from bootnav.errors import InputError
from bootnav.logger.recording import RecordingReader, load

REPO = Path(__file__).resolve().parents[1]
RECORDINGS = sorted((REPO / "recordings").glob("*.h5"))


@pytest.mark.parametrize("path", RECORDINGS, ids=[p.stem for p in RECORDINGS])
def test_blocks_are_exactly_what_load_returns(path):
    rec = load(path, with_truth=False)
    with RecordingReader(path) as r:
        assert r.n == rec.n and json.dumps(r.meta, sort_keys=True) == json.dumps(rec.meta, sort_keys=True)  # NaN too
        for rows in (rec.n, 997):
            parts = [r.block(i, min(i + rows, r.n)) for i in range(0, r.n, rows)]
            t, acc, gyro, sat = (np.concatenate(p) for p in zip(*parts))
            assert np.array_equal(t, rec.t_s) and np.array_equal(acc, rec.acc_mps2)
            assert np.array_equal(gyro, rec.gyro_radps) and np.array_equal(sat, rec.saturated)
        assert np.array_equal(r.times(), rec.t_s)
        assert r.events().tobytes() == rec.events.tobytes()  # structured rows, NaN times included


def test_a_missing_file_is_a_one_line_error(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        RecordingReader(tmp_path / "nope.h5")


def test_no_other_module_decodes_the_layout():
    """The SI conversion of a stored channel (``scale_to_si`` read off a dataset's attributes) appears only in
    ``logger/recording.py``; every reader of samples goes through ``load`` or ``RecordingReader``."""
    pattern = re.compile(r"attrs\.get\(\s*[\"']scale_to_si|attrs\[\s*[\"']scale_to_si[\"']\s*\](?!\s*=)")
    found = []
    for folder in ("bootnav", "logger", "postproc", "simulator"):
        for f in (REPO / folder).rglob("*.py"):
            if f.relative_to(REPO).as_posix() != "logger/recording.py" and pattern.search(f.read_text()):
                found.append(f.relative_to(REPO).as_posix())
    assert found == []
