"""``docs/summary.schema.json`` describes the summary.json of every kind of run: ``bootnav process`` over one
block and over many (``--block-s``; one kind, ``process``), both files of a two-boot run (each foot's summary.json and two_boots.json) and
``bootnav pdr``. Each is produced by the CLI and validated; the validator (``tests/schema_subset.py``) is
shown to refuse what the schema forbids, so a passing test means something."""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import pytest

from bootnav.cli import main
from bootnav.simulator import custom
from bootnav.simulator.twoboots import simulate_two_boots, write_two_boots_h5

from .schema_subset import errors

ROOT = Path(__file__).resolve().parents[1]
SCHEMA = json.loads((ROOT / "docs" / "summary.schema.json").read_text())
STAIRS = ROOT / "recordings" / "sim_paper-stairs.h5"
WAIST = ROOT / "tests" / "data" / "waist20_seed000_synthetic.txt"


def _run(*argv) -> None:
    assert main([*map(str, argv)]) == 0


@pytest.fixture(scope="module")
def summaries(tmp_path_factory) -> dict[str, dict]:
    d = tmp_path_factory.mktemp("schema")
    _run("process", STAIRS, "--out", d / "whole", "--no-plots", "--jobs", "1", "--quiet")
    _run("process", STAIRS, "--out", d / "chunked", "--block-s", "10", "--no-plots", "--quiet")
    walk = custom("short", lambda pb: pb.stand(3).walk(6).stand(3))
    both = write_two_boots_h5(simulate_two_boots(walk, seed=1), d / "both.h5")
    _run("process", both, "--two-boots", "--out", d / "two", "--no-plots", "--jobs", "1", "--quiet")
    _run("pdr", WAIST, "--out", d / "pdr", "--no-plots", "--quiet")
    files = {"process": d / "whole" / "summary.json", "process_blocks": d / "chunked" / "summary.json",
             "two_boots": d / "two" / "two_boots.json", "two_boots_foot": d / "two" / "left" / "summary.json",
             "pdr": d / "pdr" / "summary.json"}
    return {kind: json.loads(path.read_text()) for kind, path in files.items()}


@pytest.mark.parametrize("kind", ["process", "process_blocks", "two_boots", "two_boots_foot", "pdr"])
def test_every_kind_of_summary_follows_the_schema(summaries, kind):
    summary = summaries[kind]
    assert errors(summary, SCHEMA) == []
    # and it is the kind it should be (exactly one alternative of the top-level oneOf matches)
    alternative = {"two_boots_foot": "process", "process_blocks": "process"}.get(kind, kind)
    assert errors(summary, {"$ref": f"#/$defs/{alternative}"}, SCHEMA) == []


def test_software_has_one_shape(summaries):
    shapes = {kind: s["software"] for kind, s in summaries.items()}
    assert all(v == shapes["process"] for v in shapes.values()), shapes
    assert shapes["process"]["name"] == "bootnav"


def test_the_validator_refuses_what_the_schema_forbids(summaries):
    good = summaries["process"]
    cases = {
        "software as a string": lambda s: s.update(software="bootnav 0.1.0"),
        "an undocumented top-level key": lambda s: s.update(surprise=1),
        "a missing section": lambda s: s.pop("path"),
        "a wrong type inside a section": lambda s: s["path"].update(strides=3.5),
        "a fraction above 1": lambda s: s["stance"].update(fraction=1.5),
        "a NaN number": lambda s: s.update(distance_m=math.nan),
        "true for a number": lambda s: s["path"].update(distance_m=True),
    }
    for what, spoil in cases.items():
        bad = copy.deepcopy(good)
        spoil(bad)
        assert errors(bad, SCHEMA), f"the validator accepted {what}"


def test_the_validator_refuses_keywords_it_does_not_implement():
    with pytest.raises(ValueError, match="patternProperties"):
        errors({}, {"patternProperties": {}})
