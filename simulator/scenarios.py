"""Named scenarios: each builds a stride sequence (``PathBuilder``) from a seeded generator.

Geometry constants are the scenario's documented truth (see docs/simulator.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from bootnav.simulator.gait import RUN, SHUFFLE, STAIRS_DOWN, STAIRS_UP, WALK, PathBuilder


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


def mixed(rng: np.random.Generator, duration=1800.0) -> PathBuilder:
    """Random mix (seeded): walks with turns, standing, shuffling, turning on the spot, stair flights up
    and back down, short runs, walks at different cadences and stride lengths."""
    pb = PathBuilder().stand(10.0)
    flights = []  # flights climbed so far; going down repeats the last one, so floors stay consistent
    while pb.t < duration - 10.0:
        kind = rng.choice(["walk", "walk", "walk", "stand", "shuffle", "turn", "stairs", "run"])
        if kind == "walk":
            g = replace(WALK, stride_length_m=float(rng.uniform(1.0, 1.6)), cadence_spm=float(rng.uniform(90, 125)))
            heading = pb.yaw + float(rng.uniform(-math.pi, math.pi))
            d = float(rng.uniform(3.0, 25.0))
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
        Scenario("paper-straight", "seed-004 straight walk: 9 m, 7 strides, 10 s still at start and end",
                 paper_straight),
        Scenario("paper-stairs", "seed-004 stairs path: 11 m horizontal (3 m walk, 10 risers x 0.17 m, 5 m walk), "
                 "1.70 m climb", paper_stairs),
        Scenario("rectangle", "closed 10 m x 6 m loop (32 m), ends where it started", rectangle),
        Scenario("three-floors", "U-shaped stairwell, 3 floors x 3 m (54 risers x 1/6 m), turning landings",
                 three_floors),
        Scenario("mixed-30min", "seeded random mix of walking, turns, standing, shuffling, stairs up/down, "
                 "running (30 min)", mixed, 1800.0),
        Scenario("running", "running laps of a 60 m x 30 m rectangle (60 s; 2.6 m strides, 170 steps/min)",
                 running, 60.0),
        Scenario("long", "benchmark: walking laps of a 20 m x 10 m loop with a stair flight, 1 h", long_loop, 3600.0),
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
