"""Property test: whatever damage a text log suffers, the importer either raises InputError or keeps
every undamaged line, exactly, and reports each damaged line by number. Never any other exception."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bootnav.errors import InputError
from bootnav.logger.importers import read_any

N = 60
G = 9.80665


def base_lines():
    rng = np.random.default_rng(11)
    t = np.arange(N) / 100.0
    acc = rng.normal(0, 0.05, (N, 3)) + [0, 0, G]
    gyro = rng.normal(0, 0.05, (N, 3))
    rows = [",".join(f"{v:.5f}" for v in (t[i], *acc[i], *gyro[i])) for i in range(N)]
    return "t_s,ax_mps2,ay_mps2,az_mps2,gx_radps,gy_radps,gz_radps", rows


junk = st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\n\r\x00"), max_size=40)


def _is_data_row(text: str) -> bool:
    """A line the importer may keep as a sample: 7 comma-separated numbers."""
    fields = text.split(",")
    try:
        return len(fields) == 7 and all(np.isfinite(float(f)) for f in fields)
    except ValueError:
        return False


@settings(max_examples=60, deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(damage=st.dictionaries(st.integers(0, N - 1), junk, max_size=12), cut=st.integers(0, 30))
def test_damaged_lines_reported_good_lines_kept(tmp_path_factory, damage, cut):
    header, rows = base_lines()
    lines = list(rows)
    for k, text in damage.items():
        lines[k] = text
    body = "\n".join([header, *lines]) + "\n"
    if cut:  # power loss: the last `cut` characters are missing
        body = body[:-cut]
    path = tmp_path_factory.mktemp("fz") / "x.csv"
    path.write_text(body, encoding="utf-8")
    try:
        r = read_any(path)
    except InputError as exc:  # a refusal names the file, on one line
        assert str(path) in str(exc) or path.name in str(exc)
        assert "\n" not in str(exc)
        return
    # every undamaged, complete line is present with its exact time
    after = body.split("\n")
    intact = [k for k in range(N) if k + 1 < len(after) and after[k + 1] == rows[k]]
    intact_t = {round(float(rows[k].split(",")[0]), 5) for k in intact}
    got_t = {round(float(v), 5) for v in (r.t_s + r.meta["t0_source_s"])}
    assert intact_t <= got_t
    assert r.n <= N
    skipped = {int(e["line"]) for e in r.events if e["kind"] == "skipped_line"}
    # a damaged line that is still in the file is a comment/blank line, kept as data, or reported by number:
    # it never vanishes silently
    for k, text in damage.items():
        if k + 1 >= len(after) or after[k + 1] != text:
            continue  # removed or cut by the power loss (a cut line is reported as truncated or lost)
        stripped = text.strip()
        if not stripped or stripped.startswith(("#", "%", "//")):
            continue
        assert (k + 2) in skipped or _is_data_row(text), f"line {k + 2} {text!r} dropped without a skipped_line event"
