"""Every tunable of ``bootnav calibrate`` (saved into the calibration's ``fit`` record).

Where a default comes from:

* noise: MPU6050 datasheet (rev 3.4, tables 6.1/6.2): gyro 0.005 °/s/√Hz, accelerometer 400 µg/√Hz; at the
  DLPF bandwidth of the boot (42/44 Hz) that is σ ≈ 5.7e-4 rad/s and 0.026 m/s² per sample.
* hand tremor [ENG]: a boot held on a table by hand shakes at the physiological tremor frequencies (8–12 Hz)
  with angular rates of the order of 0.01–0.03 rad/s and accelerations below 0.2 m/s²; a deliberate
  rotation between poses is ≳ 0.5 rad/s. The still thresholds sit between the two.
* goals: issue #23 (scale factors ≤ 0.05 %, misalignment ≤ 0.05°, 1σ).
* "undetermined" limits: a parameter whose 1σ exceeds half the datasheet's own spread of that parameter
  (scale σ 1 %, cross-axis σ 0.67 %, zero-g offset σ ≈ 17 mg) is no better known after the session than
  from the datasheet, so the session is refused with what to add.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

from bootnav.core.conventions import STANDARD_GRAVITY_MPS2


@dataclass
class SensorCalSettings:
    """Tunables of the calibration fit.

    window_s: moving window (s) of the still test (several tremor periods, 4–6 at 8–12 Hz).
    min_pose_s: shortest static pose used (s); the procedure asks for 2–5 s holds.
    edge_trim_s: trimmed from each end of a still run (s): the centred window lets the first/last half
        window of a motion through.
    gyro_std_max_radps: max per-axis std of the rate within the window (tremor ≲ 0.03 rad/s, noise 6e-4).
    acc_std_max_mps2: max std of |f| within the window (noise 0.026 m/s², tremor < 0.2 m/s²).
    gyro_dev_max_radps: max |window mean rate − median static rate| (rejects slow steady rotations, whose
        std is low; the median static rate is the bias, ±0.35 rad/s on an uncalibrated MPU6050).
    anchor_s: length (s) of the gravity anchors at the end of one pose and the start of the next, between
        which the gyro is integrated (long enough to average accelerometer noise to ≈ 0.3 mrad at 100 Hz,
        short enough that a slow drift of the hand during the hold does not enter).
    max_rotation_s: a motion between two poses longer than this is not used for the gyro fit (s).
    max_gap_s: a motion with a time gap (dropped samples) longer than this is not used (s).
    pose_direction_sigma_rad: a-priori 1σ of a pose's gravity direction (tremor and accelerometer noise);
        only the relative weight against ``turn_heading_sigma_rad`` matters (the scale of the covariance
        comes from the residuals).
    turn_heading_sigma_rad: 1σ with which a person turns a boot by a full turn on a flat surface by eye
        [ENG]: 10° (with a mark or a table edge to return to, 1–2°). It weighs the 2πn constraint of a turn;
        at 10° a turn observes the scale about the vertical only to ≈ 3 %, so the scale and cross-axis
        terms of every axis come from the hand rotations about it while it is horizontal.
    turn_min_rad: a motion between two poses with the same gravity direction that turns at least this far
        about the vertical is a full turn (1.5π: more than a half turn, so n = round(angle / 2π) ≥ 1).
    turn_max_tilt_rad: max angle between the gravity directions before and after a full turn.
    temp_span_min_degc: bias temperature coefficients are fitted only when the static poses span at least
        this many °C (the die warms ≈ 3 °C after power-on; a coefficient from a smaller span, extrapolated
        over the tens of °C a boot in a fire sees, adds more error than it removes).
    acc_bias_repeatability_mps2, gyro_bias_repeatability_radps: 1σ of the turn-on-to-turn-on change of the
        biases [ENG]: no figure is published for the MPU6050; a quarter of the datasheet's turn-on tolerance
        (zero-g ±50 mg, ZRO ±20 °/s, as 3σ) is the project's assumption (docs/simulator.md, "The split r").
        Sessions of different power-ons share b + k ΔT only up to it: it weighs what two sessions at two
        temperatures say about k, and is added to the stored bias's 1σ.
    gravity_mps2: local gravity; None -> WGS-84 normal gravity at latitude_deg, height_m
        (``postproc.calibration.normal_gravity``).
    goal_scale_sigma, goal_misalignment_sigma_rad: the goals (1σ, dimensionless and rad).
    undetermined_scale_sigma, undetermined_misalignment_sigma_rad, undetermined_acc_bias_sigma_mps2:
        beyond these 1σ a parameter is not determined and the session is refused.
    """

    window_s: float = 0.5
    min_pose_s: float = 1.0
    edge_trim_s: float = 0.25
    gyro_std_max_radps: float = 0.05
    acc_std_max_mps2: float = 0.3
    gyro_dev_max_radps: float = 0.05
    anchor_s: float = 1.0
    max_rotation_s: float = 30.0
    max_gap_s: float = 0.1
    pose_direction_sigma_rad: float = 1e-3
    turn_heading_sigma_rad: float = math.radians(10.0)
    turn_min_rad: float = 1.5 * math.pi
    turn_max_tilt_rad: float = math.radians(5.0)
    temp_span_min_degc: float = 5.0
    acc_bias_repeatability_mps2: float = 0.25 * 50e-3 / 3 * STANDARD_GRAVITY_MPS2
    gyro_bias_repeatability_radps: float = 0.25 * math.radians(20.0) / 3
    gravity_mps2: float | None = None
    latitude_deg: float = 45.0
    height_m: float = 0.0
    goal_scale_sigma: float = 5e-4
    goal_misalignment_sigma_rad: float = math.radians(0.05)
    undetermined_scale_sigma: float = 5e-3
    undetermined_misalignment_sigma_rad: float = 0.0033
    undetermined_acc_bias_sigma_mps2: float = 0.08

    def gravity(self) -> float:
        from bootnav.postproc.calibration import normal_gravity

        return float(self.gravity_mps2) if self.gravity_mps2 is not None else normal_gravity(self.latitude_deg,
                                                                                               self.height_m)

    def to_dict(self) -> dict:
        return asdict(self)
