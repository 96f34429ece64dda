"""``TwoBootSettings``: every tunable of the two-boot fusion, saved with its results.

The bound γ on the distance between the two foot sensors [Skog2012] comes from anthropometry, not from data:
the feet of a walker are never further apart than about one leg length. The leg (floor to greater
trochanter) is 0.530 × body height [Winter2009, segment lengths after Drillis & Contini]; for a tall adult
(1.90 m) that is 1.0 m. A walking step (heel to heel) is at most about 0.85 × leg length even in fast
walking (step length ≈ 0.4-0.45 × body height [Perry2010]), and both sensors sit on the instep, so 1.0 m
bounds every walking or stair step of an adult with a margin; running (steps up to ~1.3 m) is outside it,
which is why the bound is a setting. Prateek et al. use 0.61 m [Prateek2013], a bound that holds only at
double support of a slow walk; the issue suggests 0.9-1.2 m.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from bootnav.errors import InputError

CLOCK_MODES = ("recording", "gait")
INSTANTS = ("stance-midpoints", "stance")


@dataclass
class TwoBootSettings:
    """Tunables of the two-boot fusion (SI units).

    Attributes
    ----------
    max_separation_m : float, m
        γ, the largest possible distance between the two foot sensors (module docstring).
    constraint_sigma_m : float, m
        1-σ of the separation bound used as a pseudo-measurement: how far the sensors may be outside the
        anthropometric bound (the sensor's lever arm on the boot, about 1 cm). Small: the projection is
        nearly hard, as in [Skog2012].
    constraint_gate_sigma : float
        Consistency gate g of the bound, in standard deviations of the separation: a violation more than g σ
        outside the two filters' covariances is applied with a larger R (``constraint.separation_variance_m2``),
        only as far as it is consistent; 0 (default): no gate, always the hard projection, which keeps the
        feet's relative error within γ + their true distance at every check. 3 (the usual 3-σ gate of a
        scalar innovation) keeps the walker nearer the common mode on stairs but lets the feet drift apart
        there (docs/twoboots.md, docs/tuning-log.md).
    instants : str
        When the bound is checked: ``"stance-midpoints"`` (once in the middle of every stance phase of
        either foot: one foot rests, so its position is the best known) or ``"stance"`` (every sample of
        every stance phase of either foot, sub-sampled to ``stance_check_interval_s``).
    stance_check_interval_s : float, s
        Spacing of the checks in ``"stance"`` mode.
    heading_alignment_m : float, m
        Both feet travel together, so the right foot's navigation frame is turned (yaw only) until its
        displacement after this much walked distance points where the left foot's does (each foot's
        initial yaw is unobservable at rest and set to 0 by the alignment of its own sensor).
    heading_alignment_sigma_rad : float, rad
        1-σ of that alignment, the right filter's initial yaw uncertainty (the left frame is the reference):
        the relative heading drift of two single feet over 30 m is a degree or two on the developer data.
    right_start_m : tuple of 2 floats, m
        Where the right foot's sensor stands relative to the left one's at the start, (forward, left) in
        ``right_start_frame`` (each filter starts at its own origin; the bound compares positions in one
        frame). Default: standing side by side, the feet about a hip width apart (0.2 m between the insteps).
    right_start_frame : str
        ``"walk"``: forward = the direction of the left foot's first 2 m walked (a walker starts facing
        the way they go; the sensor's own axes are unknown); ``"left-sensor"``: forward = the left sensor's
        x axis at the start (a known mounting, e.g. the simulator's).
    clock : str
        ``"recording"``: the recordings' ``t_s`` are one session clock (a multi-boot recording, or two files
        of one synchronised system); ``"gait"``: shift the right foot's clock by the gait-symmetry estimate
        (``align.gait_clock_offset``), for two files without a common clock.
    right_offset_s : float, s
        Added to the right foot's ``t_s`` before anything else (a known offset between two files).
    """

    max_separation_m: float = 1.0
    constraint_sigma_m: float = 0.01
    constraint_gate_sigma: float = 0.0
    instants: str = "stance-midpoints"
    stance_check_interval_s: float = 0.1
    heading_alignment_m: float = 30.0
    heading_alignment_sigma_rad: float = math.radians(2.0)
    right_start_m: tuple[float, float] = (0.0, -0.2)
    right_start_frame: str = "walk"
    clock: str = "recording"
    right_offset_s: float = 0.0

    def validate(self) -> None:
        """Raise ``InputError`` naming the bad field."""
        for name in ("max_separation_m", "constraint_sigma_m", "stance_check_interval_s", "heading_alignment_m",
                     "heading_alignment_sigma_rad"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"two-boot setting {name} must be a positive number, got {v!r}")
        g = self.constraint_gate_sigma
        if not (isinstance(g, (int, float)) and math.isfinite(g) and g >= 0):
            raise InputError(f"two-boot setting constraint_gate_sigma must be a number >= 0 (0: no gate), got {g!r}")
        if self.instants not in INSTANTS:
            raise InputError(f"two-boot setting instants must be one of {', '.join(INSTANTS)}, got {self.instants!r}")
        if len(self.right_start_m) != 2 or not all(math.isfinite(float(v)) for v in self.right_start_m):
            raise InputError(f"two-boot setting right_start_m must be two finite numbers (forward, left), "
                             f"got {self.right_start_m!r}")
        if self.right_start_frame not in ("walk", "left-sensor"):
            raise InputError(f"two-boot setting right_start_frame must be 'walk' or 'left-sensor', "
                             f"got {self.right_start_frame!r}")
        if self.clock not in CLOCK_MODES:
            raise InputError(f"two-boot setting clock must be one of {', '.join(CLOCK_MODES)}, got {self.clock!r}")
        if not math.isfinite(self.right_offset_s):
            raise InputError(f"two-boot setting right_offset_s must be finite, got {self.right_offset_s!r}")

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict | None) -> "TwoBootSettings":
        """From a (partial) dict; an unknown key is a one-line ``InputError``."""
        data = dict(data or {})
        names = {f.name for f in dataclasses.fields(cls)}
        bad = sorted(set(data) - names)
        if bad:
            raise InputError(f"unknown two-boot setting(s) {', '.join(bad)}; known: {', '.join(sorted(names))}")
        if "right_start_m" in data:
            data["right_start_m"] = tuple(data["right_start_m"])
        out = cls(**data)
        out.validate()
        return out
