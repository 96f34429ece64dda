"""Two boots of one walker: the left and the right foot's recordings, exact truth, one session clock.

The scenario's stride sequence is the LEFT foot's path. The right foot follows the same sequence half a
walking stride period later (``phase_s``, the alternation of the feet), its rest positions offset in the
foot's yaw frame by half a walking stride forward (``step_length_m``: at double support one foot is a step
ahead of the other) and ``step_width_m`` to the right (the lateral distance between the feet's paths; adult
walking 0.08-0.15 m [Perry2010]). The offset rotates with the left foot's yaw, so the right foot is a rigid
lever of the left foot delayed in time: every channel stays an exact C3 trajectory (``trajectory.py``) and
the right foot is exactly still whenever the delayed left foot is. At the start both feet stand still in a
step posture, the right sensor ``step_length_m`` ahead along the left sensor's x axis (tell the fusion:
``TwoBootSettings(right_start_m=(step_length_m, -step_width_m), right_start_frame="left-sensor")``), the right
one ``phase_s`` longer; at the end the left foot waits ``phase_s`` for the right one.

Each foot gets its own sensor with independent errors (turn-on biases, noise, bias walks, drops: the error
model of ``imu_model.py`` with its own seed). Both feet are on one session clock: ``t_s`` is the true sample
time (a host-receive alignment without error; each device's own clock error stays in ``t_device``), written
as one multi-boot recording (``write_two_boots_h5``, ``docs/recording-format.md``) or two single-boot files
(``write_two_boots``).

While the walker goes straight, the true distance between the two sensors stays below about one stride minus
``step_length_m`` (with the step width and the swing's lift: 0.82 m at most on ``mixed-walk``, 1.0-1.6 m
strides; ``max_separation_m`` measures it). The right foot is a rigid lever of the left one, so a scenario
whose legs turn WHILE walking (``walk_to`` with a large turn: the foot walks sideways for a few strides) puts
it off the walker's path, up to 2 m from the left foot; for two boots use scenarios that turn on the spot
(``mixed-walk``, ``custom`` with ``turn_in_place``).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from bootnav.core import atomic
from bootnav.simulator.gait import WALK, YAW
from bootnav.simulator.scenarios import Scenario, get_scenario
from bootnav.simulator.simulate import DEFAULT_PROFILE, DEFAULT_RATE_HZ, DEFAULT_SEED, SimResult, simulate
from bootnav.simulator.trajectory import Trajectory

LABELS = ("left", "right")


@dataclass(frozen=True)
class WalkerGeometry:
    """Where the right foot is relative to the left (module docstring); SI units."""

    step_width_m: float = 0.15
    step_length_m: float = WALK.stride_length_m / 2.0
    phase_s: float = WALK.period_s / 2.0


def _sin_cos_jets(psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """sin and cos of jets (K, 4) = (value, d1, d2, d3) by the chain rule, (K, 4) each."""
    x0, x1, x2, x3 = psi.T
    s, c = np.sin(x0), np.cos(x0)
    sin_j = np.column_stack([s, c * x1, -s * x1**2 + c * x2, -c * x1**3 - 3 * s * x1 * x2 + c * x3])
    cos_j = np.column_stack([c, -s * x1, -c * x1**2 - s * x2, s * x1**3 - 3 * c * x1 * x2 - s * x3])
    return sin_j, cos_j


def right_foot(left: Trajectory, geo: WalkerGeometry) -> Trajectory:
    """The right foot's trajectory: the left one delayed by ``phase_s``, offset in its yaw frame."""
    knots = left.knots.copy()
    sin_j, cos_j = _sin_cos_jets(knots[:, YAW, :])
    fwd, lat = geo.step_length_m, -geo.step_width_m  # right of the direction of travel: negative lateral
    knots[:, 0, :] += fwd * cos_j - lat * sin_j
    knots[:, 1, :] += fwd * sin_j + lat * cos_j
    first = knots[:1].copy()
    first[:, :, 1:] = 0.0  # the first knot is a rest knot (the builder starts at rest)
    return Trajectory(np.concatenate([[0.0], left.t_knots + geo.phase_s]), np.concatenate([first, knots]),
                      np.concatenate([[True], left.piece_still]))


def left_foot(left: Trajectory, geo: WalkerGeometry) -> Trajectory:
    """The left foot's trajectory with a still end of ``phase_s`` (both recordings end together)."""
    last = left.knots[-1:].copy()
    last[:, :, 1:] = 0.0
    return Trajectory(np.concatenate([left.t_knots, [left.t_knots[-1] + geo.phase_s]]),
                      np.concatenate([left.knots, last]), np.concatenate([left.piece_still, [True]]))


class _FootPath:
    """What ``simulate`` needs of a scenario's builder, for one foot of the pair."""

    def __init__(self, builder, traj: Trajectory, delay_s: float):
        self._builder, self._traj, self._delay = builder, traj, delay_s

    def build(self) -> Trajectory:
        return self._traj

    def step_table(self) -> dict[str, np.ndarray]:
        table = self._builder.step_table()
        for key in ("t_start_s", "t_toe_off_s", "t_heel_strike_s", "t_end_s"):
            table[key] = table[key] + self._delay
        return table

    def gait_list(self) -> list[dict]:
        return self._builder.gait_list()


def foot_seed(seed: int, label: str) -> int:
    """Independent seed of one foot's sensor errors (a SeedSequence child of the walk's seed)."""
    return int(np.random.SeedSequence([int(seed), LABELS.index(label)]).generate_state(1)[0])


def simulate_two_boots(scenario: str | Scenario, seed: int = DEFAULT_SEED, profile=DEFAULT_PROFILE,
                       rate_hz: float = DEFAULT_RATE_HZ, duration_s: float | None = None,
                       geometry: WalkerGeometry | None = None, progress=None) -> dict[str, SimResult]:
    """Both feet of one walker (module docstring): ``{"left": SimResult, "right": SimResult}``.

    Parameters
    ----------
    scenario, seed, profile, rate_hz, duration_s
        As ``simulate``; ``seed`` draws the walk, each foot's sensor errors get their own ``foot_seed``.
    geometry
        The right foot's offset and delay (default ``WalkerGeometry()``).
    progress
        ``progress(fraction)`` over both feet.

    Returns
    -------
    dict
        One ``SimResult`` per foot, ``t_s`` on the session clock (true sample time), ``attrs`` with the
        geometry and the foot label.
    """
    geo = geometry or WalkerGeometry()
    sc = get_scenario(scenario)
    builder = sc.make(np.random.default_rng(seed), duration_s)
    if not hasattr(builder, "steps"):
        raise ValueError(f"scenario {sc.name!r} is not a walk; two boots need a walking scenario")
    walk = builder.build()
    paths = {"left": _FootPath(builder, left_foot(walk, geo), 0.0),
             "right": _FootPath(builder, right_foot(walk, geo), geo.phase_s)}
    out = {}
    for i, label in enumerate(LABELS):
        foot = Scenario(sc.name, f"{sc.description} ({label} foot of two)", lambda rng, d, p=paths[label]: p)
        sub = None if progress is None else (lambda f, i=i: progress((i + f) / 2.0))
        res = simulate(foot, seed=foot_seed(seed, label), profile=profile, rate_hz=rate_hz,
                       mount=f"{label}_boot", progress=sub)
        res.t_s = res.truth["t_s"] - res.truth["t_s"][0]
        if len(res.events):
            res.events["t_s"] = res.t_s[res.events["sample_index"]]
        res.attrs.update(seed=int(seed), foot=label, foot_error_seed=foot_seed(seed, label),
                         two_boot_geometry=json.dumps({k: float(v) for k, v in vars(geo).items()}))
        out[label] = replace(res, seed=int(seed))
    return out


def _recording_kwargs(res: SimResult) -> dict:
    """``write_recording`` keyword arguments of one foot (as ``writers.write_h5`` writes a single one)."""
    from bootnav.logger.mpu6050 import TEMP_LSB_PER_DEGC
    from bootnav.logger.recording import counts_channel, si_channel
    from bootnav.simulator.writers import recording_meta

    p = res.profile
    kw = dict(t_s=res.t_s, acc=res.acc, gyro=res.gyro, events=res.events, meta=recording_meta(res),
              saturated=res.saturated)
    if res.counts:
        kw.update(acc_channel=counts_channel("acc", p.accel_lsb_mps2),
                  gyro_channel=counts_channel("gyro", p.gyro_lsb_radps),
                  t_device=res.t_device, seq=res.seq, temp=res.temp,
                  temp_channel=counts_channel("temp", 1.0 / TEMP_LSB_PER_DEGC))
    else:
        kw.update(acc_channel=si_channel("acc"), gyro_channel=si_channel("gyro"))
    return kw


def _check_free(paths: list[Path], force: bool) -> None:
    from bootnav.core.paths import output_file

    for p in paths:  # the one output rule (bootnav.core.paths)
        output_file(p, force=force, hdf5=True)


def write_two_boots_h5(results: dict[str, SimResult], path: str | os.PathLike, force: bool = False) -> Path:
    """One multi-boot recording (``docs/recording-format.md``) with ``/boots/<label>/truth`` per foot
    (crash-safe: temp + rename; refuses to overwrite unless ``force``)."""
    from bootnav.logger.recording import write_group, write_multi_boot
    from bootnav.simulator.writers import TRUTH_DESCRIPTION, TRUTH_UNITS, step_arrays

    path = Path(path)
    _check_free([path], force)

    def write(tmp: Path) -> None:
        write_multi_boot(tmp, {label: _recording_kwargs(res) for label, res in results.items()},
                         attrs={"session_start_unix_s": float("nan")})
        for label, res in results.items():
            meta = {"clock_alignment": "simulated (session clock = true sample time)", "clock_offset_s": 0.0}
            write_group(tmp, f"boots/{label}/truth", {**res.truth, **step_arrays(res)},
                        attrs={**res.attrs, "description": TRUTH_DESCRIPTION, **meta}, units=TRUTH_UNITS)

    atomic.replace_with(path, write)
    return path


def write_two_boots(results: dict[str, SimResult], out: str | os.PathLike, force: bool = False) -> list[Path]:
    """Write both feet as two single-boot recordings ``<out stem>_left.h5`` and ``<out stem>_right.h5``
    (crash-safe: temp + rename; refuses to overwrite unless ``force``). Returns the paths written."""
    from bootnav.simulator.writers import write_h5

    out = Path(out)
    stem = out.name[:-3] if out.name.lower().endswith(".h5") else out.name
    paths = [out.with_name(f"{stem}_{label}.h5") for label in results]
    _check_free(paths, force)
    for p, res in zip(paths, results.values()):
        atomic.replace_with(p, lambda tmp, res=res: write_h5(res, tmp))
    return paths


def sensor_position_n(res: SimResult) -> np.ndarray:
    """True sensor positions (N, 3) in the walk's frame (the left foot starts at the origin), m."""
    from bootnav.simulator.imu_synth import synthesize

    start = synthesize(res.trajectory, res.truth["t_s"][:1], res.mount).pos_n[0]
    return res.truth["pos_n_m"] + start


def max_separation_m(results: dict[str, SimResult]) -> float:
    """Largest true distance between the two feet's sensors over the session (m)."""
    a, b = results["left"], results["right"]
    pa, pb = sensor_position_n(a), sensor_position_n(b)
    pb_on_a = np.column_stack([np.interp(a.truth["t_s"], b.truth["t_s"], pb[:, i]) for i in range(3)])
    return float(np.max(np.linalg.norm(pa - pb_on_a, axis=1)))


__all__ = ["WalkerGeometry", "simulate_two_boots", "write_two_boots", "write_two_boots_h5", "foot_seed",
           "max_separation_m", "sensor_position_n", "right_foot", "left_foot", "LABELS", "run_cli"]


def run_cli(args) -> int:
    """``bootnav simulate --two-boots``: simulate both feet and write them (``simulator/cli.py`` options)."""
    import time

    from bootnav.errors import InputError

    if args.format == "sd-txt" or str(args.out).lower().endswith(".txt"):
        raise InputError("--two-boots writes HDF5 recordings; give --out NAME.h5")
    t0 = time.perf_counter()
    try:
        res = simulate_two_boots(args.scenario, seed=args.seed, profile=args.sensor_profile, rate_hz=args.rate,
                                 duration_s=args.duration)
    except ValueError as exc:
        raise InputError(str(exc)) from exc
    paths = (write_two_boots(res, args.out, args.force) if args.two_files
             else [write_two_boots_h5(res, args.out, args.force)])
    left = res["left"]
    dist = float(np.sum(left.steps["length_m"]))
    print(f"{', '.join(map(str, paths))}: {args.scenario}, two boots, {left.n} + {res['right'].n} samples at "
          f"{left.rate_hz:g} Hz ({left.t_s[-1]:.1f} s), {len(left.steps['length_m'])} strides per foot, {dist:.1f} m, "
          f"largest distance between the feet {max_separation_m(res):.2f} m, seed {args.seed} "
          f"[{time.perf_counter() - t0:.1f} s]")
    return 0
