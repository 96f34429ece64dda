"""Named scenarios: each builds a stride sequence (``PathBuilder``) from a seeded generator.

Geometry constants are the scenario's documented truth (see docs/simulator.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from bootnav.simulator.calibration import make_session
from bootnav.simulator.gait import CRAWL, FAST, RUN, SHUFFLE, STAIRS_DOWN, STAIRS_UP, WALK, PathBuilder


@dataclass(frozen=True)
class Scenario:
    name: str
    description: str
    build: Callable[[np.random.Generator, float | None], PathBuilder]
    default_duration_s: float | None = None  # None: fixed geometry, --duration not accepted

    def make(self, rng: np.random.Generator, duration_s: float | None = None) -> PathBuilder:
        if duration_s is not None and self.default_duration_s is None:
            raise ValueError(f"scenario {self.name!r} has a fixed path; --duration applies only to "
                             f"{', '.join(n for n, s in SCENARIOS.items() if s.default_duration_s)}")
        if duration_s is not None and duration_s <= 0:
            raise ValueError(f"duration must be > 0 s, got {duration_s}")
        return self.build(rng, duration_s if duration_s is not None else self.default_duration_s)


def paper_straight(rng, duration=None) -> PathBuilder:
    """Seed-004 section 4: straight 9 m walk; 10 s still before and after (alignment, ZUPT check)."""
    return PathBuilder().stand(10.0).walk(9.0, replace(WALK, stride_length_m=1.30)).stand(10.0)


PAPER_STAIRS = dict(approach_m=3.0, n_risers=10, riser_m=0.17, tread_m=0.30, top_m=5.0)


def paper_stairs(rng, duration=None) -> PathBuilder:
    """Seed-004 section 4: 11 m path (horizontal) climbing a staircase. The paper gives no stair geometry;
    chosen: 3 m approach, 10 risers x 0.17 m with 0.30 m treads (3 m), 5 m on the upper floor."""
    g = PAPER_STAIRS
    pb = PathBuilder().stand(10.0).walk(g["approach_m"])
    pb.stairs(g["n_risers"], g["riser_m"], g["tread_m"], up=True)
    return pb.walk(g["top_m"]).stand(10.0)


def rectangle(rng, duration=None) -> PathBuilder:
    """Closed 10 m x 6 m loop (32 m), counter-clockwise, back to the start point; still 5 s at both ends."""
    pb = PathBuilder().stand(5.0)
    for x, y in ((10.0, 0.0), (10.0, 6.0), (0.0, 6.0), (0.0, 0.0)):
        pb.walk_to(x, y)
    return pb.stand(5.0)


THREE_FLOORS = dict(floors=3, floor_height_m=3.0, risers_per_flight=9, tread_m=0.28, landing_m=1.2)


def three_floors(rng, duration=None) -> PathBuilder:
    """Three floors up a U-shaped stairwell: per floor 2 flights of 9 risers x 1/6 m, turning landings."""
    g = THREE_FLOORS
    n = g["risers_per_flight"]
    riser = g["floor_height_m"] / (2 * n)
    run = n * g["tread_m"]
    w, a = g["landing_m"], 3.0
    pb = PathBuilder().stand(5.0).walk(a)
    for _ in range(g["floors"]):
        pb.stairs(n, riser, g["tread_m"])  # east, along y = 0
        pb.walk_to(a + run + 0.5, 0.0).walk_to(a + run + 0.5, w).walk_to(a + run, w)  # half landing
        pb.stairs(n, riser, g["tread_m"])  # west, along y = w
        pb.walk_to(a - 0.5, w).walk_to(a - 0.5, 0.0).walk_to(a, 0.0)  # floor landing
    return pb.walk(3.0).stand(5.0)


def running(rng, duration=60.0) -> PathBuilder:
    """Running laps of a 60 m x 30 m rectangle for ``duration`` s, after a short walk; still at both ends."""
    pb = PathBuilder().stand(5.0).walk(5.0)
    corners = ((65.0, 0.0), (65.0, 30.0), (5.0, 30.0), (5.0, 0.0))
    i = 0
    while pb.t < duration - 5.0:
        pb.walk_to(*corners[i % 4], gait=RUN, max_turn_deg=30.0)
        i += 1
    return pb.stand(5.0)


CRAWL_SCENARIO = dict(walk_in_m=6.0, first_leg_m=9.0, turn_deg=90.0, turn_strides=6, second_leg_m=8.0,
                      stride_m=(0.22, 0.38), cadence_spm=(54.0, 66.0), pause_s=3.0, walk_out_m=6.0)


def _crawl_leg(pb: PathBuilder, distance_m: float, rng: np.random.Generator, turn_rad: float = 0.0,
               turn_strides: int = 0) -> None:
    """Crawl ``distance_m`` in strides of seeded length and cadence (CRAWL_SCENARIO ranges); the first
    ``turn_strides`` strides share ``turn_rad`` (the path curves through the turn)."""
    g = CRAWL_SCENARIO
    n = max(1, round(distance_m / CRAWL.stride_length_m))
    lengths = rng.uniform(*g["stride_m"], n)
    lengths *= distance_m / lengths.sum()
    for i, length in enumerate(lengths):
        gait = replace(CRAWL, cadence_spm=float(rng.uniform(*g["cadence_spm"])))
        pb.stride(float(length), 0.0, turn_rad / turn_strides if i < turn_strides else 0.0, gait)


def crawl(rng: np.random.Generator, duration=None) -> PathBuilder:
    """Firefighter search in smoke: walk in, kneel, crawl on hands and knees (two legs with a 90 deg turn of
    seeded direction and a pause), get up, walk out. The boot rests on its toe while crawling."""
    g = CRAWL_SCENARIO
    pb = PathBuilder().stand(5.0).walk(g["walk_in_m"]).stand(2.0).kneel().stand(2.0)
    _crawl_leg(pb, g["first_leg_m"], rng)
    pb.stand(g["pause_s"])
    side = float(rng.choice([-1.0, 1.0]))
    _crawl_leg(pb, g["second_leg_m"], rng, side * math.radians(g["turn_deg"]), g["turn_strides"])
    pb.stand(2.0).stand_up().stand(2.0)
    return pb.walk(g["walk_out_m"]).stand(5.0)


FAST_CORRIDOR = dict(corridor_m=40.0, stride_m=(2.1, 2.5), ramp_m=(1.3, 1.9), still_s=(0.10, 0.20))


def _fast(stride_m: float, still_s: float):
    """The FAST gait at ``stride_m``, foot flat and still for ``still_s``; cadence grows with the stride,
    150 steps/min at 2.5 m (assumption)."""
    cadence = FAST.cadence_spm * math.sqrt(stride_m / 2.5)
    return replace(FAST, stride_length_m=stride_m, cadence_spm=cadence, still_fraction=still_s * cadence / 120.0)


def fast_corridor(rng: np.random.Generator, duration=120.0) -> PathBuilder:
    """Fast, near-running walks up and down a straight corridor for ``duration`` s: per length, two strides
    to speed up, seeded cruising strides of 2.1-2.5 m with a seeded foot-flat of 0.1-0.2 s, two strides to
    slow down, a 180 deg turn on the spot."""
    g = FAST_CORRIDOR
    slow, mid = g["ramp_m"]
    pb = PathBuilder().stand(5.0)
    side = 1.0
    while pb.t < duration - 5.0:
        still = float(rng.uniform(*g["still_s"]))
        pb.stride(slow, gait=replace(WALK, stride_length_m=slow)).stride(mid, gait=_fast(mid, still))
        pb.walk(g["corridor_m"] - 2 * (slow + mid), _fast(float(rng.uniform(*g["stride_m"])), still))
        pb.stride(mid, gait=_fast(mid, still)).stride(slow, gait=replace(WALK, stride_length_m=slow))
        pb.turn_in_place(side * math.pi)
        side = -side
    return pb.stand(5.0)


SHUFFLE_SCENARIO = dict(stride_m=(0.10, 0.30), strides=(4, 15), cadence_spm=(80.0, 110.0), stand_s=(0.5, 3.0),
                        turn_deg=(45.0, 180.0))


def shuffle(rng: np.random.Generator, duration=60.0) -> PathBuilder:
    """Shuffling search for ``duration`` s: runs of seeded short steps (0.1-0.3 m, 3 cm clearance), a pause,
    a turn on the spot of seeded size and direction."""
    g = SHUFFLE_SCENARIO
    pb = PathBuilder().stand(5.0)
    while pb.t < duration - 5.0:
        length = float(rng.uniform(*g["stride_m"]))
        gait = replace(SHUFFLE, stride_length_m=length, cadence_spm=float(rng.uniform(*g["cadence_spm"])))
        pb.walk(int(rng.integers(g["strides"][0], g["strides"][1] + 1)) * length, gait)
        pb.stand(float(rng.uniform(*g["stand_s"])))
        pb.turn_in_place(float(rng.choice([-1, 1]) * math.radians(rng.uniform(*g["turn_deg"]))))
    return pb.stand(5.0)


MIXED_KINDS = ("walk", "walk", "walk", "stand", "shuffle", "turn", "stairs", "run")


def mixed(rng: np.random.Generator, duration=1800.0, kinds=MIXED_KINDS, walk_turn_deg: float | None = None) -> PathBuilder:
    """Random mix (seeded): walks with turns, standing, shuffling, turning on the spot, stair flights up
    and back down, short runs, walks at different cadences and stride lengths (``kinds``: the draw's choices;
    ``walk_turn_deg``: a walk first turns on the spot to within that angle of its leg, so no stride goes
    sideways; None: the whole turn happens while walking)."""
    pb = PathBuilder().stand(10.0)
    flights = []  # flights climbed so far; going down repeats the last one, so floors stay consistent
    while pb.t < duration - 10.0:
        kind = rng.choice(list(kinds))
        if kind == "walk":
            g = replace(WALK, stride_length_m=float(rng.uniform(1.0, 1.6)), cadence_spm=float(rng.uniform(90, 125)))
            heading = pb.yaw + float(rng.uniform(-math.pi, math.pi))
            d = float(rng.uniform(3.0, 25.0))
            if walk_turn_deg is not None:
                dyaw = (heading - pb.yaw + math.pi) % (2 * math.pi) - math.pi
                limit = math.radians(walk_turn_deg)
                if abs(dyaw) > limit:
                    pb.turn_in_place(dyaw - math.copysign(limit, dyaw))
            pb.walk_to(pb.pos[0] + d * math.cos(heading), pb.pos[1] + d * math.sin(heading), g)
        elif kind == "stand":
            pb.stand(float(rng.uniform(1.0, 20.0)))
        elif kind == "shuffle":
            pb.walk(float(rng.uniform(0.5, 3.0)), SHUFFLE)
        elif kind == "turn":
            pb.turn_in_place(float(rng.choice([-1, 1]) * rng.uniform(math.pi / 4, math.pi)))
        elif kind == "stairs":
            up = not flights or (len(flights) < 3 and rng.random() < 0.5)
            if up:
                flights.append((int(rng.integers(6, 17)), float(rng.uniform(0.15, 0.19)),
                                float(rng.uniform(0.26, 0.32))))
                n, riser, tread = flights[-1]
            else:
                n, riser, tread = flights.pop()
            pb.stairs(n, riser, tread, up=up, gait=STAIRS_UP if up else STAIRS_DOWN)
            pb.walk(float(rng.uniform(1.0, 3.0)))
            pb.turn_in_place(math.pi)
        else:
            pb.walk(float(rng.uniform(10.0, 40.0)), RUN)
    return pb.stand(10.0)


def long_loop(rng: np.random.Generator, duration=3600.0) -> PathBuilder:
    """Benchmark generator: laps of a 20 m x 10 m loop with one 8-riser flight up and down per lap."""
    pb = PathBuilder().stand(10.0)
    legs = (lambda: pb.walk_to(20.0, 0.0), lambda: pb.walk_to(20.0, 10.0),
            lambda: pb.stairs(8, 0.17, 0.28, up=True), lambda: pb.turn_in_place(math.pi),
            lambda: pb.stairs(8, 0.17, 0.28, up=False), lambda: pb.walk_to(0.0, 10.0), lambda: pb.walk_to(0.0, 0.0))
    i = 0
    while pb.t < duration - 10.0:  # stop after the leg that reaches the duration
        legs[i % len(legs)]()
        i += 1
    return pb.stand(10.0)


SCENARIOS: dict[str, Scenario] = {
    s.name: s
    for s in (
        Scenario("paper-straight", "[Heidari2019] straight walk: 9 m, 7 strides, 10 s still at start and end",
                 paper_straight),
        Scenario("paper-stairs", "[Heidari2019] stairs path: 11 m horizontal (3 m walk, 10 risers x 0.17 m, 5 m walk), "
                 "1.70 m climb", paper_stairs),
        Scenario("rectangle", "closed 10 m x 6 m loop (32 m), ends where it started", rectangle),
        Scenario("three-floors", "U-shaped stairwell, 3 floors x 3 m (54 risers x 1/6 m), turning landings",
                 three_floors),
        Scenario("mixed-30min", "seeded random mix of walking, turns, standing, shuffling, stairs up/down, "
                 "running (30 min)", mixed, 1800.0),
        Scenario("mixed-walk", "the mixed draw without running: walking, turns, standing, shuffling, stairs "
                 "up/down, a walk turns on the spot first (10 min; two-boot benchmark)",
                 lambda rng, duration: mixed(rng, duration, MIXED_KINDS[:-1], 20.0), 600.0),
        Scenario("running", "running laps of a 60 m x 30 m rectangle (60 s; 2.6 m strides, 170 steps/min)",
                 running, 60.0),
        Scenario("long", "benchmark: walking laps of a 20 m x 10 m loop with a stair flight, 1 h", long_loop, 3600.0),
        Scenario("crawl", "firefighter in smoke: walk 6 m, kneel, crawl 17 m on hands and knees (90 deg turn), "
                 "stand up, walk 6 m", crawl),
        Scenario("fast-corridor", "fast near-running strides (2.1-2.5 m, 137-150 steps/min, foot flat 0.1-0.2 s) "
                 "along a 40 m corridor, 180 deg turns on the spot (120 s)", fast_corridor, 120.0),
        Scenario("shuffle", "shuffling search: 0.1-0.3 m steps, pauses, turns on the spot (60 s)", shuffle, 60.0),
        Scenario("calibration", "hand-held calibration on a table: 23 static poses held 2-5 s (tremor), rotations "
                 "about every boot axis, 3 full turns on the table (~2 min; simulator/calibration.py)", make_session),
    )
}


def get_scenario(name: str | Scenario) -> Scenario:
    if isinstance(name, Scenario):
        return name
    try:
        return SCENARIOS[name]
    except KeyError:
        raise ValueError(f"unknown scenario {name!r}; choose one of {', '.join(SCENARIOS)}") from None


def custom(name: str, build: Callable[[PathBuilder], PathBuilder], description: str = "") -> Scenario:
    """A scenario from a function that adds segments to a fresh PathBuilder (Python API users, tests)."""
    return Scenario(name, description or name, lambda rng, duration: build(PathBuilder()))
