"""Issue 26, point 4 (charts): path.html has a key of its floor colours, none of which is the start marker's;
chart 7 of a level walk has no legend entry for a stair line it does not draw."""

from __future__ import annotations

import re

import pytest

from tests.conftest import REPO


@pytest.fixture(scope="module")
def results():
    from bootnav.postproc.pipeline import process
    from bootnav.postproc.settings import ProcessSettings

    out = {}
    for name, floor_h in (("sim_paper-straight", 3.0), ("sim_paper-stairs", 1.5)):
        s = ProcessSettings(floor_height_m=floor_h)  # the paper's 1.7 m climb counts as one 1.5 m storey
        out[name] = process(REPO / "recordings" / f"{name}.h5", s)
    return out


def test_path_html_has_a_floor_key_distinct_from_the_markers(results, tmp_path):
    from bootnav.postproc.plots import END_COLOR, FLOOR_COLORS, START_COLOR, make_html

    page = make_html(results["sim_paper-stairs"], tmp_path).read_text()
    lines = dict(re.findall(r'<polyline class="path" data-floor="(-?\d+)" style="stroke:(#[0-9a-f]{6})"', page))
    keys = dict(re.findall(r'<span class="key" data-floor="(-?\d+)"><span class="sw" style="background:(#[0-9a-f]{6})"',
                           page))
    assert len(lines) >= 2 and keys == lines  # every drawn floor has its key entry, in its colour
    start = re.search(r'<circle id="start"[^>]*fill:(#[0-9a-f]{6})', page)[1]
    end = re.search(r'<circle id="end"[^>]*fill:(#[0-9a-f]{6})', page)[1]
    assert (start, end) == (START_COLOR, END_COLOR)
    assert not {start, end} & set(FLOOR_COLORS)  # no floor is drawn in a marker's colour


def _legends(result, tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    from bootnav.postproc.plots import ChartStream, draw_charts

    seen = []
    original = Figure.savefig

    def record(fig, *a, **k):
        for ax in fig.axes:
            if ax.get_legend() is not None:
                seen.extend(t.get_text() for t in ax.get_legend().get_texts())
        return original(fig, *a, **k)

    with monkeypatch.context() as m:
        m.setattr(Figure, "savefig", record)
        draw_charts(ChartStream.from_result(result), tmp_path, keys=("height",))
    return seen


def test_height_chart_names_only_what_it_draws(results, tmp_path, monkeypatch):
    level = _legends(results["sim_paper-straight"], tmp_path / "a", monkeypatch)
    stairs = _legends(results["sim_paper-stairs"], tmp_path / "b", monkeypatch)
    assert level and not any("stair height" in t for t in level), level
    assert any("stair height" in t for t in stairs), stairs
