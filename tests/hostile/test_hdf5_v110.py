"""Every HDF5 file bootnav writes is read by the HDF5 1.10 tools (Debian's ``hdf5-tools``, MATLAB).

``h5dump`` of a recorded (pty, SWMR writer), an imported, a simulated and a processed file must
print every dataset without an error. Skipped only when ``h5dump`` is not installed
(``scripts/install-debian-deps.sh`` installs it).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import h5py
import pytest

from bootnav.cli import main
from tests.test_serial_record import emulate_and_record

H5DUMP = shutil.which("h5dump")
pytestmark = pytest.mark.skipif(H5DUMP is None, reason="h5dump not installed (apt-get install hdf5-tools)")


def _datasets(path: Path) -> list[str]:
    names = []
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: names.append("/" + name) if isinstance(obj, h5py.Dataset) else None)
        for key in f:  # results.h5 links its recording's groups (HDF5 external links), which h5dump follows
            if not isinstance(f.get(key, getlink=True), h5py.ExternalLink):
                continue
            if isinstance(f[key], h5py.Dataset):
                names.append(f"/{key}")
            else:
                f[key].visititems(lambda name, obj, key=key: names.append(f"/{key}/{name}")
                                  if isinstance(obj, h5py.Dataset) else None)
    return names


def _assert_h5dump_reads_everything(path: Path) -> None:
    version = subprocess.run([H5DUMP, "--version"], capture_output=True, text=True).stdout
    assert re.search(r"1\.(8|10|12|14)\.", version), f"not an HDF5 1.x h5dump: {version}"
    names = _datasets(path)
    assert "/imu/acc" in names and "/imu/t_s" in names
    proc = subprocess.run([H5DUMP, "-H", str(path)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == 0 and "error" not in proc.stderr.lower(), proc.stderr
    for name in names:  # the data too: a compressed chunk in a format 1.10 lacks fails only here
        proc = subprocess.run([H5DUMP, "-d", name, str(path)], capture_output=True, text=True, timeout=60)
        assert proc.returncode == 0 and "error" not in proc.stderr.lower(), f"{name}: {proc.stderr}"


def test_recorded_file_is_hdf5_110(tmp_path):
    out, _, _ = emulate_and_record(tmp_path, ["--duration", "1", "--rate", "200"])
    _assert_h5dump_reads_everything(out)


def test_imported_simulated_and_processed_files_are_hdf5_110(tmp_path, capsys):
    csv = tmp_path / "walk.csv"
    csv.write_text("t,ax,ay,az,gx,gy,gz\n" + "".join(f"{i / 100},0.1,0.2,9.8,0.01,0,0\n" for i in range(500)))
    imported = tmp_path / "walk.h5"
    assert main(["import", str(csv), "--out", str(imported), "--acc-unit", "mps2", "--gyro-unit", "radps",
                 "--quiet"]) == 0
    _assert_h5dump_reads_everything(imported)
    sim = tmp_path / "sim.h5"
    assert main(["simulate", "--scenario", "paper-straight", "--out", str(sim), "--quiet"]) == 0
    _assert_h5dump_reads_everything(sim)
    assert main(["process", str(sim), "--out", str(tmp_path / "res"), "--quiet"]) == 0
    written = sorted((tmp_path / "res").glob("*.h5")) or [sim]  # results beside the outputs, or in the input
    for path in written:
        _assert_h5dump_reads_everything(path)
        assert any(n.startswith("/results/") for n in _datasets(path))
    capsys.readouterr()


@pytest.mark.parametrize("path", sorted((Path(__file__).resolve().parents[2] / "recordings").glob("*.h5")),
                         ids=lambda p: p.name)
def test_bundled_recordings_are_hdf5_110(path):
    _assert_h5dump_reads_everything(path)
