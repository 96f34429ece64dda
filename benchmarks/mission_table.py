"""The mission table of issue 24: uncalibrated / calibrated × aids off / on, per scenario, from the JSON files of
``benchmarks/mission.py`` runs (one run per aid setting, told apart by ``--label``).

    nice -n 10 .venv/bin/python benchmarks/mission.py --scenarios building --variants uncal cal --devices 20 \
        --jobs 2 --label "aids off" --json off.json
    nice -n 10 .venv/bin/python benchmarks/mission.py --scenarios building --variants uncal cal --devices 20 \
        --jobs 2 --set filter.heading_aid='"auto"' --label "heading aid auto" --json auto.json
    .venv/bin/python benchmarks/mission_table.py off.json auto.json

Per (scenario, variant, label): walks, failures, median / worst final horizontal error, ARMSE, the share of
stance samples within 1.5 m of the true height (median / lowest) and the final height error; and, for labels
compared on the same walks, how many walks the later label made better than the first. Prints markdown; it
asserts nothing.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np


def load_rows(paths: list[Path]) -> list[dict]:
    rows = []
    for p in paths:
        data = json.loads(Path(p).read_text())
        rows += data["rows"] if isinstance(data, dict) else data
    return rows


def _fig(vals, worst=max) -> str:
    vals = [v for v in vals if v is not None and np.isfinite(v)]
    return f"{np.median(vals):.2f} / {worst(vals):.2f}" if vals else "–"


def _on(rows: list[dict]) -> str:
    """How many walks ``heading_aid = "auto"`` switched on (rows of runs without it: –)."""
    dec = [r["heading_aid_on"] for r in rows if "heading_aid_on" in r]
    return f"{sum(dec)}/{len(dec)}" if dec else "–"


def table(rows: list[dict]) -> str:
    keys = []
    for r in rows:
        k = (r["scenario"], r["variant"], r.get("label", ""))
        if k not in keys:
            keys.append(k)
    out = ["| scenario | variant | aids | walks (failed) | final h (m) median / worst | ARMSE h (m) median / worst "
           "| stance in 1.5 m (%) median / lowest | final v (m) median / worst | better than the first label | auto on |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for scen, var, lab in keys:
        rs = [r for r in rows if (r["scenario"], r["variant"], r.get("label", "")) == (scen, var, lab)]
        ok = [r for r in rs if "error" not in r]
        first = next(k for k in keys if k[:2] == (scen, var))
        better = "–"
        if first[2] != lab:
            base = {r["device"]: r for r in rows if (r["scenario"], r["variant"], r.get("label", "")) == first
                    and "error" not in r}
            pairs = [(r["final_h_m"], base[r["device"]]["final_h_m"]) for r in ok if r["device"] in base]
            better = f"{sum(a < b for a, b in pairs)}/{len(pairs)}"
        out.append(f"| {scen} | {var} | {lab or '–'} | {len(rs)} ({len(rs) - len(ok)}) | "
                   f"{_fig([r.get('final_h_m') for r in ok])} | {_fig([r.get('armse_h_m') for r in ok])} | "
                   f"{_fig([r.get('stance_within_tol_pct') for r in ok], worst=min)} | "
                   f"{_fig([abs(r['final_v_m']) if r.get('final_v_m') is not None else None for r in ok])} | "
                   f"{better} | {_on(ok)} |")
    return "\n".join(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("json", nargs="+", type=Path, help="benchmarks/mission.py --json outputs")
    args = ap.parse_args(argv)
    print(table(load_rows(args.json)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
