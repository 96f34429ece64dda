"""Rebuild recordings/: small example recordings in the bootnav format, each with its reference.

Real walks come from the public datasets beside the repository (../shared/datasets) and are imported with
the same importers users run; simulated ones come from `bootnav simulate` with a fixed seed. Run:

    .venv/bin/python scripts/make_recordings.py [DATASETS_ROOT]
"""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
OUT = REPO / "recordings"


def main(root: Path) -> None:
    from bootnav.logger.importers import import_file
    from bootnav.simulator import simulate, write_h5

    OUT.mkdir(exist_ok=True)
    raw = root / "raw-formats"
    real = [
        # (output name, source file, reference written beside it)
        ("xio_ngimu_short_walk.h5", raw / "xio_ngimu_csv" / "short_walk.csv",
         {"closed_loop": True, "approx_length_m": 25.0}),
        ("openshoe_820_loop.h5", raw / "openshoe_820_txt" / "OpenShoeDataSet.txt",
         {"closed_loop": True}),
        ("gaitmap_level_walk_left.h5", root / "gaitmap_example" / "level_walk" / "imu_left.csv.gz", None),
    ]
    for name, src, reference in real:
        out = OUT / name
        import_file(src, out, mount="left_boot" if "left" in name else "foot")
        if reference is not None:
            (OUT / name.replace(".h5", ".reference.json")).write_text(json.dumps(reference, indent=1) + "\n")
        print(f"{out.relative_to(REPO)}: {out.stat().st_size / 1e6:.2f} MB from {src.name}")
    strides = root / "gaitmap_example" / "level_walk" / "truth_strides.csv"
    shutil.copy(strides, OUT / "gaitmap_level_walk_left.truth_strides.csv")

    for scenario in ("paper-straight", "paper-stairs"):
        result = simulate(scenario, seed=1)
        out = OUT / f"sim_{scenario}.h5"
        write_h5(result, out)
        print(f"{out.relative_to(REPO)}: {out.stat().st_size / 1e6:.2f} MB (simulated, truth inside)")


if __name__ == "__main__":
    sys.path.insert(0, str(REPO))
    main(Path(sys.argv[1]) if len(sys.argv) > 1 else REPO.parent / "shared" / "datasets")
