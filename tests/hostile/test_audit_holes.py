"""Holes of the test audit (issue 14 point 7) that belong to no single module's test file."""

from __future__ import annotations

import ast
from pathlib import Path

from bootnav.postproc.pipeline import process

REPO = Path(__file__).resolve().parents[2]
STAGES = ("load", "stance_floor", "timing", "navigation", "strides")  # the passes of ``passes.BlockPasses``


def test_every_stage_is_timed_and_the_stages_add_up_to_at_most_the_total():
    r = process(REPO / "recordings" / "sim_paper-straight.h5")
    timings = r.summary["timings_s"]
    assert all(timings[stage] > 0.0 for stage in STAGES), timings  # perf_counter: every stage takes some time
    assert sum(timings[s] for s in STAGES) <= timings["total_process"] * (1 + 1e-9), timings


def test_no_test_skips_on_an_import_error_of_the_project_itself():
    """``pytest.importorskip("bootnav...")`` would turn a broken module of ours into a quiet skip."""
    offenders = []
    for path in sorted((REPO / "tests").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if (isinstance(node, ast.Call) and getattr(node.func, "attr", "") == "importorskip" and node.args
                    and isinstance(node.args[0], ast.Constant) and str(node.args[0].value).startswith("bootnav")):
                offenders.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert offenders == []
