"""Shared test helpers.

``reopen_in_fresh_process`` proves a file is complete on disk: a new interpreter opens it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DATASETS = Path(os.environ.get("BOOTNAV_DATASETS", REPO.parent / "shared" / "datasets"))


def run_python(code: str, *args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    """Run ``code`` in a fresh Python process (argv[1:] = args); raise with its stderr on failure."""
    proc = subprocess.run(
        [sys.executable, "-c", code, *args], capture_output=True, text=True, timeout=timeout, cwd=REPO
    )
    if proc.returncode != 0:
        raise AssertionError(f"fresh process failed ({proc.returncode}):\n{proc.stderr}")
    return proc


def reopen_in_fresh_process(path) -> dict:
    """Load a recording in a new process; return a JSON summary with SHA-256 of each SI array."""
    code = (
        "import sys, json, hashlib, numpy as np\n"
        "from bootnav.logger.recording import load\n"
        "r = load(sys.argv[1])\n"
        "h = lambda a: hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()\n"
        "print(json.dumps({'n': r.n, 't_s': h(r.t_s), 'acc_raw': h(r.raw['acc']), 'gyro_raw': h(r.raw['gyro']),"
        " 'acc_mps2': h(r.acc_mps2), 'n_events': int(len(r.events)), 'meta': {k: str(v) for k, v in r.meta.items()}}))\n"
    )
    return json.loads(run_python(code, str(path)).stdout)


def sha(a) -> str:
    import hashlib

    import numpy as np

    return hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest()


@pytest.fixture
def datasets() -> Path:
    if not DATASETS.exists():
        pytest.skip(f"public datasets not found at {DATASETS}")
    return DATASETS
