"""One installed import name, ``bootnav``: editable and wheel installs both work.

The design card keeps ``logger/``, ``postproc/`` and ``simulator/`` at the top of the repository; they install
as ``bootnav.logger``, ``bootnav.postproc`` and ``bootnav.simulator`` (``pyproject.toml`` ``package-dir``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import sysconfig
import tomllib
import zipfile
from pathlib import Path

import pytest

from tests.conftest import REPO

MAPPED = {"bootnav": "bootnav", "bootnav.logger": "logger", "bootnav.postproc": "postproc",
          "bootnav.simulator": "simulator"}


def _declared_packages() -> list[str]:
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    assert cfg["package-dir"] == MAPPED
    return cfg["packages"]


def _package_folders() -> set[str]:
    """Every folder with an __init__.py below the mapped roots, as its installed dotted name."""
    names = set()
    for name, folder in MAPPED.items():
        for init in (REPO / folder).rglob("__init__.py"):
            rel = init.parent.relative_to(REPO / folder)
            names.add(".".join([name, *rel.parts]) if rel.parts else name)
    return names


def test_every_package_folder_is_declared():
    assert set(_declared_packages()) == _package_folders()


def test_package_data_lives_in_declared_packages():
    """setuptools prints a 40-line warning at every install for a package-data file in a folder Python can
    import but ``packages`` does not list (issue 26: ``bootnav.postproc.live.static``)."""
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]
    declared = set(cfg["packages"])
    for pkg, patterns in cfg["package-data"].items():
        for pattern in patterns:
            folder = pattern.rsplit("/", 1)[0] if "/" in pattern else ""
            if folder and pkg != "*":
                assert f"{pkg}.{folder.replace('/', '.')}" in declared, (pkg, pattern)
    static = REPO / "postproc" / "live" / "static"
    assert {p.name for p in static.iterdir() if p.suffix in (".html", ".js", ".css")} == {
        "index.html", "live.js", "live.css"}


@pytest.mark.parametrize("name", ["logger", "postproc", "simulator"])
def test_old_top_level_names_do_not_import(name, tmp_path):
    # from the repository root (where the folders are on sys.path) and from elsewhere
    for cwd in (REPO, tmp_path):
        proc = subprocess.run([sys.executable, "-c", f"import {name}"], cwd=cwd, capture_output=True, text=True)
        assert proc.returncode != 0, f"'import {name}' worked from {cwd}"
    proc = subprocess.run([sys.executable, "-c", f"import bootnav.{name}"], cwd=tmp_path, capture_output=True,
                          text=True)
    assert proc.returncode == 0, proc.stderr


def test_user_module_named_logger_does_not_shadow(tmp_path):
    (tmp_path / "logger.py").write_text("raise RuntimeError('the user logger module was imported')\n")
    (tmp_path / "postproc.py").write_text("raise RuntimeError('the user postproc module was imported')\n")
    code = "from bootnav.postproc.pipeline import process; import bootnav.logger.recording; print('ok')"
    proc = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


@pytest.mark.slow
def test_wheel_installs_into_a_fresh_venv_and_processes(tmp_path):
    """Build a wheel, install it (no deps) into a new venv that borrows only the third-party packages."""
    dist = tmp_path / "dist"
    build = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                            "-w", str(dist), str(REPO)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert build.returncode == 0, build.stderr
    assert "absent from the `packages` configuration" not in build.stdout + build.stderr
    wheels = list(dist.glob("bootnav-*.whl"))
    assert len(wheels) == 1
    top = {n.split("/")[0] for n in zipfile.ZipFile(wheels[0]).namelist() if not n.startswith("bootnav-")}
    assert top == {"bootnav"}, f"wheel installs top-level names {sorted(top)}"

    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True)
    vpy = venv / "bin" / "python"
    site = subprocess.run([str(vpy), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                          capture_output=True, text=True, check=True).stdout.strip()
    # third-party dependencies from the project's environment: a plain path entry (its .pth files, among them
    # the editable install of bootnav, are not processed)
    Path(site, "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    inst = subprocess.run([sys.executable, "-m", "pip", "--python", str(vpy), "install", "--no-deps", "--no-index",
                           "-q", str(wheels[0])], capture_output=True, text=True, timeout=300)
    assert inst.returncode == 0, inst.stderr
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH",)}
    where = subprocess.run([str(vpy), "-c", "import bootnav.postproc, sys; print(bootnav.postproc.__file__)"],
                           capture_output=True, text=True, cwd=tmp_path, env=env)
    assert where.returncode == 0, where.stderr
    assert Path(where.stdout.strip()).is_relative_to(venv), where.stdout
    exe = venv / "bin" / "bootnav"
    help_ = subprocess.run([str(exe), "--help"], capture_output=True, text=True, cwd=tmp_path, env=env)
    assert help_.returncode == 0 and "process" in help_.stdout, help_.stderr
    rec = REPO / "recordings" / "xio_ngimu_short_walk.h5"
    out = tmp_path / "out"
    run = subprocess.run([str(exe), "process", str(rec), "--out", str(out), "--no-plots", "--no-hdf5"], capture_output=True,
                         text=True, cwd=tmp_path, env=env, timeout=300)
    assert run.returncode == 0, run.stderr
    assert (out / "summary.json").exists() and (out / "trajectory.csv").exists()
