"""bootnav from Python, notebook style (each ``# %%`` is a cell; run as a script, or paste into Jupyter).

Uses the repository's bundled x-io walk (a 23 m closed loop); ``tests/test_api.py`` executes this file.
Run: ``.venv/bin/python docs/api-example.py [OUTDIR]``.
"""

# %% load a recording (a bootnav .h5, or any file `bootnav import` reads: CSV, SD-card log, ...)
import sys
import tempfile
from pathlib import Path

import numpy as np

import bootnav

rec = bootnav.load(Path(__file__).resolve().parents[1] / "recordings" / "xio_ngimu_short_walk.h5")
print(f"{rec.n} samples at {rec.rate_hz:.0f} Hz, {rec.t_s[-1] - rec.t_s[0]:.1f} s")

# %% reconstruct the path; settings are keywords (any ProcessSettings field, nested ones as dicts)
res = bootnav.process(rec, reference='{"closed_loop": true}', detector={"method": "adaptive"})
print(res)
print(f"distance {res.summary['distance_m']:.2f} m, closure {res.metrics['closure_pct']:.2f} % of it")
print("last position (m, east-north-up):", np.round(res.pos_n_m[-1], 3))
print("stride lengths (m):", np.round(res.steps["stride_length_m"], 2))

# %% the same from plain arrays (SI units, sensor frame): e.g. data from your own logger
t_s, acc_mps2, gyro_radps = rec.t_s, rec.acc_mps2, rec.gyro_radps
res_arrays = bootnav.process(t_s, acc_mps2, gyro_radps, crop_s=(0.0, 30.0))
print(res_arrays)

# %% tables (pandas is optional: the arrays above need none)
try:
    df = res.to_dataframe()  # t_s, x_m, y_m, z_m, vx_mps, vy_mps, vz_mps, stance
    print(df.describe().loc[["min", "max"], ["x_m", "y_m", "z_m"]])
    print(res.steps_dataframe()[["t_s", "stride_length_m", "heading_deg_cw_from_north"]].head())
except ImportError as exc:
    print(exc)

# %% step-and-heading (PDR) for a sensor that is not on the foot (here the same foot, for the example)
steps = bootnav.pdr(t_s, acc_mps2, gyro_radps, heading="gyro")
print(steps, "- mean step", round(float(np.mean(steps.length_m)), 2), "m")

# %% write every file `bootnav process --out DIR` writes (CSV, summary.json, results.h5, charts, path.html)
out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()) / "walk"
files = res.save(out)
print("wrote", len(files), "files into", out)
