"""Issue 27, "user files destroyed": one output rule for every writer (``bootnav.core.paths``), outputs as a set.

Every case compares the SHA-256 of the user's files before and after the command.
"""

from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import pytest

from bootnav.cli import main
from bootnav.core import atomic
from bootnav.errors import InputError

REC = Path(__file__).resolve().parents[2] / "recordings" / "sim_paper-straight.h5"


def sha(p: Path) -> str:
    return hashlib.sha256(Path(p).read_bytes()).hexdigest()


@pytest.fixture
def files(tmp_path):
    rec = tmp_path / "rec.h5"
    shutil.copy(REC, rec)
    notes = tmp_path / "notes.txt"
    notes.write_text("field notes, not HDF5\n")
    return rec, notes


@pytest.mark.timeout(60)
@pytest.mark.parametrize("argv, target, words", [
    (["simulate", "--scenario", "paper-straight", "--out", "{rec}"], "rec", "--force"),
    (["simulate", "--scenario", "paper-straight", "--format", "h5", "--out", "{notes}"], "notes", "not an HDF5"),
    (["simulate", "--scenario", "paper-straight", "--format", "h5", "--out", "{notes}", "--force"], "notes",
     "not an HDF5"),
    (["simulate", "--scenario", "paper-straight", "--out", "{tmp}/new.h5", "--plot", "{rec}"], "rec", "--force"),
    (["record", "--port", "loop://", "--out", "{notes}", "--force", "--duration", "0.5"], "notes", "not an HDF5"),
    (["emulate", "--out-link", "{rec}", "--duration", "1", "--no-wait"], "rec", "exists"),
    (["import", "{notes}", "--out", "{rec}"], "rec", "--force"),
    (["process", "{rec}", "--save-settings", "{notes}", "--out", "{tmp}/o"], "notes", "--force"),
    (["pdr", "{rec}", "--save-settings", "{notes}", "--out", "{tmp}/o"], "notes", "--force"),
])
def test_every_writer_refuses_to_destroy_a_file(files, tmp_path, capsys, argv, target, words):
    rec, notes = files
    paths = {"rec": rec, "notes": notes}
    before = {k: sha(p) for k, p in paths.items()}
    argv = [a.replace("{rec}", str(rec)).replace("{notes}", str(notes)).replace("{tmp}", str(tmp_path)) for a in argv]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert words in err and "unexpected" not in err and "internal error" not in err
    assert {k: sha(p) for k, p in paths.items()} == before
    assert not (tmp_path / "new.h5").exists()  # refused before any work


def test_policy_rules(tmp_path):
    from bootnav.core.paths import output_file, output_folder

    notes = tmp_path / "notes.txt"
    notes.write_text("x")
    rec = tmp_path / "r.h5"
    shutil.copy(REC, rec)
    with pytest.raises(InputError, match="not an HDF5"):
        output_file(notes, force=True, hdf5=True)
    assert output_file(notes, force=True) == notes  # a text output may replace a text file with --force
    with pytest.raises(InputError, match="replace an input"):
        output_file(rec, force=True, inputs=[rec], hdf5=True)
    with pytest.raises(InputError, match="does not exist"):
        output_file(tmp_path / "nodir" / "x.h5")
    with pytest.raises(InputError, match="is a directory"):
        output_file(tmp_path, force=True)
    os.mkfifo(tmp_path / "fifo")
    with pytest.raises(InputError, match="FIFO"):
        output_file(tmp_path / "fifo", force=True)
    link = tmp_path / "link.h5"
    link.symlink_to(rec.name)
    assert output_file(link, force=True, hdf5=True) == rec.resolve()  # written through to the target
    with pytest.raises(InputError, match="not a folder"):
        output_folder(notes, ["a.csv"])


def test_a_symlink_is_written_through_and_stays_a_link(tmp_path):
    target = tmp_path / "target.txt"
    target.write_text("old")
    link = tmp_path / "link.txt"
    link.symlink_to(target.name)
    atomic.write_text(link, "new")
    assert link.is_symlink() and target.read_text() == "new"


def test_output_set_is_all_or_none(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    with pytest.raises(OSError):
        with atomic.output_set([out / "a.csv", out / "b.csv", out / "c.csv"]):
            atomic.write_text(out / "a.csv", "a")
            (out / "c.csv").write_text("written by a helper process")  # not deferred: removed on failure
            raise OSError(28, "No space left on device")
    assert sorted(p.name for p in out.iterdir()) == []
    with atomic.output_set([out / "a.csv", out / "b.csv"]):
        atomic.write_text(out / "a.csv", "a")
        assert not (out / "a.csv").exists()  # deferred to the end of the set
        atomic.write_text(out / "b.csv", "b")
    assert sorted(p.name for p in out.iterdir()) == ["a.csv", "b.csv"]


def test_process_error_after_results_h5_leaves_no_partial_set(tmp_path, monkeypatch):
    """A clean error while the CSVs are written must not leave results.h5 alone."""
    from bootnav.postproc import outputs
    from bootnav.postproc.cli_process import _one
    from bootnav.postproc.settings import ProcessSettings

    def broken(*a, **k):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(outputs, "write_steps_csv", broken)
    s = ProcessSettings()
    s.output.plots = False
    with pytest.raises(OSError):
        _one(str(REC), s, str(tmp_path / "o"), None)
    left = sorted(p.name for p in (tmp_path / "o").iterdir()) if (tmp_path / "o").exists() else []
    assert left == []


@pytest.mark.timeout(60)
def test_eval_refuses_a_non_empty_out_and_with_force_clears_only_its_own_files(tmp_path, capsys):
    from bootnav.postproc.evaluate.cli import prepare_out

    out = tmp_path / "ev"
    (out / "plots").mkdir(parents=True)
    (out / "mine.txt").write_text("keep me")
    (out / "metrics.json").write_text('{"trials": {"a/1": {}}, "written": ["plots/a__1__x.png", "report.md", '
                                      '"metrics.json", "../escape.txt"]}')
    (out / "report.md").write_text("old report")
    (out / "plots" / "a__1__x.png").write_bytes(b"old plot")
    (tmp_path / "escape.txt").write_text("outside")
    root = tmp_path / "data"
    root.mkdir()
    (root / "manifest.json").write_text('{"trials": [{"id": "x/1", "set": "x"}]}')
    assert main(["eval", str(root), "--out", str(out)]) == 1
    assert "not empty" in capsys.readouterr().err
    assert (out / "report.md").exists()
    prepare_out(out, force=True)
    assert sorted(p.name for p in out.rglob("*")) == ["mine.txt", "plots"]
    assert (tmp_path / "escape.txt").read_text() == "outside"


@pytest.mark.timeout(120)
def test_into_recording_on_a_symlink_writes_through_to_the_target(tmp_path, capsys):
    target = tmp_path / "data" / "walk.h5"
    target.parent.mkdir()
    shutil.copy(REC, target)
    link = tmp_path / "walk.h5"
    link.symlink_to(target)
    assert main(["process", str(link), "--into-recording", "--out", str(tmp_path / "o"), "--no-plots"]) == 0
    import h5py

    assert link.is_symlink() and os.readlink(link) == str(target)  # the link stays a link
    with h5py.File(target, "r") as f:
        assert "results/default/pos_n_m" in f  # the results went into the file it points to
    assert sorted(p.name for p in target.parent.iterdir()) == ["walk.h5"]  # no temporary left beside it
