"""Issue 26, point 5: the README is a user's guide: short, its commands real, accuracy in one table, the
long figures in docs/ (every figure the README had is still in the repository's documentation)."""

from __future__ import annotations

import re
import subprocess

from bootnav.cli import SUBCOMMANDS
from tests.conftest import REPO

README = REPO / "README.md"


def test_readme_is_a_short_guide_with_one_accuracy_table():
    text = README.read_text()
    assert len(text.splitlines()) < 120
    headers = [ln for ln in text.splitlines() if ln.startswith("|") and "| metric |" in ln]  # accuracy tables
    assert len(headers) == 1, headers
    for command in re.findall(r"^bootnav (\w+)", text, flags=re.MULTILINE):  # the command lines of the guide
        assert command in SUBCOMMANDS, command
    assert "make demo" in text and "make test" in text and "first run" in text


def test_no_figure_of_the_old_readme_is_lost():
    """Every number of the README before the guide rewrite is in the README or in docs/ now."""
    old = subprocess.run(["git", "show", "9ed1321:README.md"], capture_output=True, text=True, cwd=REPO)
    if old.returncode != 0:  # a shallow clone without that commit: nothing to compare
        return
    now = README.read_text() + "".join(p.read_text() for p in (REPO / "docs").glob("*.md"))
    figures = set(re.findall(r"\d+\.\d+\s?(?:%|m|s|ms|MB|GB|M samples/s)", old.stdout))
    lost = sorted(f for f in figures if f not in now)
    assert not lost, lost
