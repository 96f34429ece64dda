"""The ``building`` scenario: a seeded multi-storey building and a firefighter's search through it.

The plan (building coordinates, metres; x along the main corridor, rotated into the navigation frame by the
seeded building axis ``axis_rad``):

* **storeys**: 3-6, storey height h 2.8-3.5 m; every stair has n risers per storey with h / n in 0.15-0.20 m
  (n even, the value nearest a seeded riser) and treads of 0.26-0.30 m;
* **main corridor** along y = 0 from x = 0 to x = L (30-60 m), the same on every storey; **rooms** (3-6 m
  wide, 3-5 m deep) side by side on its +y side, one door each at y = 1 m;
* **U-shaped stairwell** at the far end: its door at (L + 0.5, 0), two flights of n/2 risers (east along
  y = 0, west along y = 1.2 m) with a half landing between them; the door is above itself on every storey;
* **straight stairwell** on the -y side at x2: door at (x2, -1), one flight of n risers going -y from
  (x2, -1.5); on arrival the walker returns along a 1.2 m landing lane beside the flight to the door above;
* a **45° wing** (a 5-9 m corridor leaving the main one at 45°) and a **curved corridor** (a quarter circle
  of 5-9 m radius) on the -y side, dead ends the search walks to and back;
* an **open hall** on the ground floor between the entry and the corridor (12-20 m x 10-16 m) crossed by
  legs in random directions; the **entry** door at its far side; the search starts and ends 5 m outside.

The search (``duration`` s, default 30 min, at most 60): stand at the entry, cross the hall, then on each
storey 2-4 activities (search a room walking its walls, search a room crawling along its walls on hands and
knees, walk the 45° wing or the curved corridor and back, stand and listen, cross the hall again on the
ground floor), then a stairwell (either, seeded) to the next storey: up to the top, down to the ground, up
again, until the time left is what going down and out takes; then down the nearest stairwell, along the
corridor, straight through the hall and out of the entry, and stand still until the duration is reached.

Built with ``PathBuilder`` (walk_to, stairs, turn_in_place, stand, kneel / crawl / stand_up), so every
sensor error of the simulator applies unchanged. Extra truth (``plan_truth``): the storey of every sample
(nearest storey level of the foot), whether the foot is in a stair stride, and the plan as JSON attributes
(``building_plan``: axis, storey height, risers, stairwell doors and flights in the navigation frame).
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from bootnav.simulator.gait import CRAWL, STAIRS_DOWN, STAIRS_UP, WALK, PathBuilder

BUILDING = dict(storeys=(3, 6), storey_height_m=(2.8, 3.5), riser_m=(0.15, 0.20), tread_m=(0.26, 0.30),
                corridor_m=(30.0, 60.0), room_width_m=(3.0, 6.0), room_depth_m=(3.0, 5.0), hall_m=(12.0, 20.0),
                hall_width_m=(10.0, 16.0), wing_m=(5.0, 9.0), arc_radius_m=(5.0, 9.0), landing_m=1.2,
                outside_m=5.0, max_duration_s=3600.0, min_duration_s=300.0, activities=(2, 4),
                stand_s=(2.0, 20.0), wall_margin_m=0.6, corridor_half_width_m=1.0)
ACTIVITIES = ("room", "room", "room_crawl", "wing", "arc", "stand", "hall")
WALK_SPEED_MPS = WALK.stride_length_m / WALK.period_s


@dataclass
class Plan:
    """A seeded floor plan (building coordinates; module docstring)."""

    storeys: int
    storey_height_m: float
    n_risers: int  # per storey, even
    tread_m: float
    corridor_m: float
    rooms: list  # (x_left, x_right, depth_m) on the +y side of the corridor
    x_straight: float  # straight stairwell's door at (x_straight, -1)
    x_wing: float
    wing_m: float
    x_arc: float
    arc_radius_m: float
    hall_m: float
    hall_width_m: float
    axis_rad: float
    origin: tuple = (0.0, 0.0)  # building (0, 0) in the navigation frame (the walk starts at the origin)
    regions: list = field(default_factory=list)  # walkable: ("rect", x0, y0, x1, y1) or ("seg", xa, ya, xb, yb, r)

    @property
    def riser_m(self) -> float:
        return self.storey_height_m / self.n_risers

    @property
    def u_door(self) -> tuple:
        return (self.corridor_m + 0.5, 0.0)

    @property
    def s_door(self) -> tuple:
        return (self.x_straight, -1.0)

    @property
    def entry(self) -> tuple:
        return (-self.hall_m, 0.0)

    @property
    def outside(self) -> tuple:
        return (-self.hall_m - BUILDING["outside_m"], 0.0)

    def to_nav(self, x, y):
        """Building -> navigation coordinates (arrays or floats)."""
        c, s = math.cos(self.axis_rad), math.sin(self.axis_rad)
        return self.origin[0] + c * x - s * y, self.origin[1] + s * x + c * y

    def to_building(self, x, y):
        c, s = math.cos(self.axis_rad), math.sin(self.axis_rad)
        dx, dy = np.asarray(x) - self.origin[0], np.asarray(y) - self.origin[1]
        return c * dx + s * dy, -s * dx + c * dy

    def inside(self, x, y, tol_m: float = 0.3) -> np.ndarray:
        """Whether building points (x, y) lie in a walkable region (within ``tol_m``)."""
        x, y = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(y, float))
        ok = np.zeros(x.shape, bool)
        for r in self.regions:
            if r[0] == "rect":
                _, x0, y0, x1, y1 = r
                ok |= (x >= x0 - tol_m) & (x <= x1 + tol_m) & (y >= y0 - tol_m) & (y <= y1 + tol_m)
            else:
                _, xa, ya, xb, yb, rad = r
                d = np.array([xb - xa, yb - ya])
                u = np.clip(((x - xa) * d[0] + (y - ya) * d[1]) / max(d @ d, 1e-12), 0.0, 1.0)
                ok |= np.hypot(x - xa - u * d[0], y - ya - u * d[1]) <= rad + tol_m
        return ok

    def to_attrs(self) -> dict:
        """The plan's truth as JSON-able attributes (positions in the navigation frame)."""
        nav = lambda p: [float(v) for v in self.to_nav(*p)]  # noqa: E731
        run = self.n_risers * self.tread_m
        return {
            "axis_rad": self.axis_rad, "storeys": self.storeys, "storey_height_m": self.storey_height_m,
            "n_risers_per_storey": self.n_risers, "riser_m": self.riser_m, "tread_m": self.tread_m,
            "corridor_m": self.corridor_m, "entry_n_m": nav(self.entry), "start_n_m": nav(self.outside),
            "stairwells": [
                {"kind": "u", "door_n_m": nav(self.u_door), "flights_n_m": [
                    nav((self.corridor_m + 1.0, 0.0)), nav((self.corridor_m + 1.0 + run / 2, BUILDING["landing_m"]))]},
                {"kind": "straight", "door_n_m": nav(self.s_door), "flights_n_m": [
                    nav((self.x_straight, -1.5)), nav((self.x_straight, -1.5 - run))]},
            ],
            "rooms": [list(map(float, r)) for r in self.rooms],
            "hall_m": [self.hall_m, self.hall_width_m], "wing": [self.x_wing, self.wing_m],
            "arc": [self.x_arc, self.arc_radius_m],
        }


def draw_plan(rng: np.random.Generator) -> Plan:
    """A seeded plan (module docstring); the draws happen in a fixed order."""
    g = BUILDING
    storeys = int(rng.integers(g["storeys"][0], g["storeys"][1] + 1))
    h = float(rng.uniform(*g["storey_height_m"]))
    r = float(rng.uniform(*g["riser_m"]))
    lo, hi = math.ceil(h / g["riser_m"][1] - 1e-9), math.floor(h / g["riser_m"][0] + 1e-9)
    evens = [n for n in range(lo, hi + 1) if n % 2 == 0]
    n = min(evens, key=lambda k: abs(k - h / r))
    tread = float(rng.uniform(*g["tread_m"]))
    L = float(rng.uniform(*g["corridor_m"]))
    rooms, x = [], 1.0
    while True:
        w = float(rng.uniform(*g["room_width_m"]))
        if x + w > L - 1.0:
            break
        rooms.append((x, x + w, float(rng.uniform(*g["room_depth_m"]))))
        x += w
    x2 = float(rng.uniform(0.12, 0.22)) * L
    xw = float(rng.uniform(0.40, 0.50)) * L
    wing = float(rng.uniform(*g["wing_m"]))
    xa = float(rng.uniform(0.72, 0.80)) * L
    ra = float(rng.uniform(*g["arc_radius_m"]))
    hall, hall_w = float(rng.uniform(*g["hall_m"])), float(rng.uniform(*g["hall_width_m"]))
    axis = float(rng.uniform(-math.pi, math.pi))
    plan = Plan(storeys, h, n, tread, L, rooms, x2, xw, wing, xa, ra, hall, hall_w, axis)
    plan.origin = tuple(-np.array(plan.to_nav(*plan.outside)))  # the walk starts at the navigation origin
    cw, land, run = g["corridor_half_width_m"], g["landing_m"], n * tread
    reg = [("rect", 0.0, -cw, L + 1.0, cw), ("rect", -hall, -hall_w / 2, 0.0, hall_w / 2),
           ("seg", *plan.outside, *plan.entry, cw)]
    reg += [("rect", x0, cw, x1, cw + d) for x0, x1, d in rooms]
    ux = L + 1.0
    reg.append(("rect", ux - 1.0, -0.3, ux + run / 2 + 1.0, land + 0.3))  # U stairwell
    reg.append(("rect", x2 - 0.3, -1.5 - run - 0.8, x2 + land + 0.3, -cw))  # straight stairwell and lane
    reg.append(("seg", xw, -cw, xw + wing / math.sqrt(2), -cw - wing / math.sqrt(2), cw))
    th = np.linspace(0.0, math.pi / 2, 16)
    arc = np.column_stack([xa + ra - ra * np.cos(th), -cw - ra * np.sin(th)])
    reg += [("seg", *arc[i], *arc[i + 1], cw) for i in range(len(arc) - 1)]
    plan.regions = reg
    return plan


class _Walker:
    """A PathBuilder driven in building coordinates (storey-aware)."""

    def __init__(self, plan: Plan, rng: np.random.Generator):
        self.plan, self.rng = plan, rng
        self.pb = PathBuilder(yaw0_rad=plan.axis_rad)  # facing the entry along the building's x axis
        self.storey = 0
        self.pb.plan = plan

    @property
    def xy(self):
        return self.plan.to_building(self.pb.pos[0], self.pb.pos[1])

    def to(self, x, y, gait=WALK, max_turn_deg=45.0):
        self.pb.walk_to(*self.plan.to_nav(x, y), gait=gait, max_turn_deg=max_turn_deg)

    def face(self, yaw_building_rad: float):
        d = (yaw_building_rad + self.plan.axis_rad - self.pb.yaw + math.pi) % (2 * math.pi) - math.pi
        if abs(d) > 1e-6:
            self.pb.turn_in_place(d)

    def corridor(self, x):
        """Along the corridor (y = 0) to x; first back onto it if needed."""
        bx, by = self.xy
        if abs(by) > 1e-6:
            self.to(bx, 0.0)
        self.to(x, 0.0)

    def stand(self, lo=None, hi=None):
        g = BUILDING["stand_s"]
        self.pb.stand(float(self.rng.uniform(lo or g[0], hi or g[1])))

    # -- activities ---------------------------------------------------------------------------
    def room(self, crawl: bool):
        x0, x1, d = self.plan.rooms[int(self.rng.integers(len(self.plan.rooms)))]
        cw, m = BUILDING["corridor_half_width_m"], BUILDING["wall_margin_m"]
        xd = 0.5 * (x0 + x1)
        self.corridor(xd)
        self.to(xd, cw)  # the door
        corners = [(x0 + m, cw + m), (x0 + m, cw + d - m), (x1 - m, cw + d - m), (x1 - m, cw + m)]
        if self.rng.random() < 0.5:
            corners = corners[::-1]
        if crawl:
            self.to(xd, cw + 0.4)
            self.pb.stand(1.0)
            self.pb.kneel()
            self.pb.stand(1.0)
            for cx, cy in [*corners, (xd, cw + m)]:
                bx, by = self.xy
                dist = math.hypot(cx - bx, cy - by)
                n = max(1, round(dist / CRAWL.stride_length_m))
                gait = replace(CRAWL, cadence_spm=float(self.rng.uniform(54.0, 66.0)))
                # crawl strides turn at most 15 deg each (crawl scenario)
                self.pb.walk_to(*self.plan.to_nav(cx, cy), gait=replace(gait, stride_length_m=dist / n),
                                max_turn_deg=15.0)
                self.pb.stand(float(self.rng.uniform(1.0, 4.0)))
            self.pb.stand_up()
            self.pb.stand(1.0)
        else:
            self.to(xd, cw + m)
            for cx, cy in corners:
                self.to(cx, cy)
                if self.rng.random() < 0.5:
                    self.stand(1.0, 5.0)
            self.to(xd, cw + m)
        self.to(xd, cw)
        self.to(xd, 0.0)

    def wing(self):
        p, cw = self.plan, BUILDING["corridor_half_width_m"]
        self.corridor(p.x_wing)
        self.to(p.x_wing, -cw)
        s = p.wing_m / math.sqrt(2)
        self.to(p.x_wing + s, -cw - s)
        self.stand(2.0, 8.0)
        self.to(p.x_wing, -cw)
        self.to(p.x_wing, 0.0)

    def arc(self):
        p, cw = self.plan, BUILDING["corridor_half_width_m"]
        self.corridor(p.x_arc)
        self.to(p.x_arc, -cw)
        n = max(3, math.ceil(p.arc_radius_m * math.pi / 2 / 1.2))
        th = np.linspace(0.0, math.pi / 2, n + 1)[1:]
        pts = [(p.x_arc + p.arc_radius_m * (1 - math.cos(a)), -cw - p.arc_radius_m * math.sin(a)) for a in th]
        for q in pts:
            self.to(*q, max_turn_deg=20.0)
        self.stand(2.0, 8.0)
        for q in pts[-2::-1]:
            self.to(*q, max_turn_deg=20.0)
        self.to(p.x_arc, -cw, max_turn_deg=20.0)
        self.to(p.x_arc, 0.0)

    def hall(self, legs: int | None = None):
        p = self.plan
        self.corridor(0.0)
        for _ in range(legs or int(self.rng.integers(3, 6))):
            self.to(float(self.rng.uniform(-p.hall_m + 1.0, -1.0)),
                    float(self.rng.uniform(-p.hall_width_m / 2 + 1.0, p.hall_width_m / 2 - 1.0)))
        self.to(0.0, 0.0)

    def activity(self):
        kind = self.rng.choice([a for a in ACTIVITIES if a != "hall" or self.storey == 0])
        if kind in ("room", "room_crawl"):
            self.room(kind == "room_crawl")
        elif kind == "wing":
            self.wing()
        elif kind == "arc":
            self.arc()
        elif kind == "hall":
            self.hall()
        else:
            self.stand()

    # -- stairs -------------------------------------------------------------------------------
    def change_storey(self, up: bool, which: str):
        p, land = self.plan, BUILDING["landing_m"]
        n, riser, tread = p.n_risers, p.riser_m, p.tread_m
        stairs = lambda k, heading: (self.face(heading),  # noqa: E731
                                     self.pb.stairs(k, riser, tread, up=up, gait=STAIRS_UP if up else STAIRS_DOWN))
        if which == "u":
            self.corridor(p.corridor_m)
            ax, run = p.corridor_m + 1.0, n // 2 * tread
            self.to(*p.u_door)
            if up:
                self.to(ax, 0.0)
                stairs(n // 2, 0.0)
                self.to(ax + run + 0.5, 0.0)
                self.to(ax + run + 0.5, land)
                self.to(ax + run, land)
                stairs(n // 2, math.pi)
                self.to(ax - 0.5, land)
                self.to(*p.u_door)
            else:
                self.to(ax - 0.5, land)
                self.to(ax, land)
                stairs(n // 2, 0.0)
                self.to(ax + run + 0.5, land)
                self.to(ax + run + 0.5, 0.0)
                self.to(ax + run, 0.0)
                stairs(n // 2, math.pi)
                self.to(*p.u_door)
            self.to(p.corridor_m, 0.0)
        else:
            x2, run = p.x_straight, n * tread
            self.corridor(x2)
            self.to(*p.s_door)
            if up:
                self.to(x2, -1.5)
                stairs(n, -math.pi / 2)
                self.to(x2 + land, -1.5 - run)
                self.to(x2 + land, -1.5)
                self.to(*p.s_door)
            else:
                self.to(x2 + land, -1.5)
                self.to(x2 + land, -1.5 - run)
                self.to(x2, -1.5 - run)
                stairs(n, math.pi / 2)
                self.to(*p.s_door)
            self.to(x2, 0.0)
        self.storey += 1 if up else -1

    def stair_times_s(self) -> dict:
        """Time to go down one storey by each stairwell, door to door, from a dry run on a scratch builder."""
        out = {}
        for which, x in (("u", self.plan.corridor_m), ("s", self.plan.x_straight)):
            w = _Walker(self.plan, np.random.default_rng(0))
            w.pb = PathBuilder(yaw0_rad=self.plan.axis_rad, pos=np.array([*self.plan.to_nav(x, 0.0), 10.0]))
            w.storey, t0 = 1, w.pb.t
            w.change_storey(False, which)
            out[which] = w.pb.t - t0
        return out

    def nearest_stairwell(self) -> str:
        bx, _ = self.xy
        return "u" if abs(bx - self.plan.corridor_m) < abs(bx - self.plan.x_straight) else "s"

    def exit_time_s(self, stair_s: dict) -> float:
        """Time to go down and out from here: the nearest stairwell, the corridor, the hall, the entry."""
        p, (bx, by) = self.plan, self.xy
        xs = p.corridor_m if self.nearest_stairwell() == "u" else p.x_straight
        walk = abs(by) + abs(bx - xs) * (self.storey > 0) + (xs if self.storey > 0 else abs(bx))
        return (self.storey * stair_s[self.nearest_stairwell()] + walk / WALK_SPEED_MPS
                + (p.hall_m + BUILDING["outside_m"]) / WALK_SPEED_MPS + 10.0)


def building(rng: np.random.Generator, duration: float | None = 1800.0) -> PathBuilder:
    """A seeded building and a ``duration``-second search through it (module docstring)."""
    g = BUILDING
    duration = 1800.0 if duration is None else float(duration)
    if not g["min_duration_s"] <= duration <= g["max_duration_s"]:
        raise ValueError(f"the building search lasts {g['min_duration_s']:.0f}-{g['max_duration_s']:.0f} s, "
                         f"got --duration {duration:g}")
    plan = draw_plan(rng)
    w = _Walker(plan, rng)
    w.pb.stand(10.0)
    w.to(*plan.entry)
    w.hall()
    stair_s = w.stair_times_s()
    going_up = True
    longest_activity_s = 150.0  # a crawled room: about 15 m at 0.15 m/s plus pauses
    slack = lambda: duration - w.pb.t - w.exit_time_s(stair_s)  # noqa: E731
    while slack() > longest_activity_s:
        for _ in range(int(rng.integers(g["activities"][0], g["activities"][1] + 1))):
            if slack() <= longest_activity_s:
                break
            w.activity()
        if slack() <= longest_activity_s + 2 * max(stair_s.values()):
            break
        if going_up and w.storey == plan.storeys - 1:
            going_up = False
        elif not going_up and w.storey == 0:
            going_up = True
        w.change_storey(going_up, "u" if rng.random() < 0.5 else "s")
    while slack() > 30.0:  # fill the time left with short walks along the corridor and pauses
        bx, _ = w.xy
        reach = min(plan.corridor_m, bx + 0.5 * (slack() - 20.0) * WALK_SPEED_MPS)
        w.corridor(float(rng.uniform(max(0.0, bx - (reach - bx)), reach)))
        w.stand(2.0, max(2.5, min(20.0, slack() - 10.0)))
    while w.storey > 0:
        w.change_storey(False, w.nearest_stairwell())
    w.corridor(0.0)
    w.to(*plan.entry)
    w.to(*plan.outside)
    w.pb.stand(max(10.0, duration - w.pb.t))
    w.pb.plan_truth = lambda t_s, foot_pos_n, steps: plan_truth(plan, t_s, foot_pos_n, steps)
    return w.pb


def plan_truth(plan: Plan, t_s: np.ndarray, foot_pos_n: np.ndarray, steps: dict) -> tuple[dict, dict]:
    """Per-sample plan truth and the plan's attributes.

    ``storey``: the storey level nearest the foot's height (int16; 0 = ground); ``on_stairs``: 1 inside a
    stride that climbs or descends (uint8). Attributes: ``building_plan`` (JSON, ``Plan.to_attrs``) and
    ``building_axis_rad`` (yaw of the building's x axis in the navigation frame, ENU)."""
    storey = np.rint(foot_pos_n[:, 2] / plan.storey_height_m).astype(np.int16)
    on = np.zeros(len(t_s), np.uint8)
    sel = np.abs(steps["dz_m"]) > 1e-9
    if sel.any():
        i0 = np.searchsorted(t_s, steps["t_start_s"][sel], side="left")
        i1 = np.searchsorted(t_s, steps["t_end_s"][sel], side="right")
        delta = np.zeros(len(t_s) + 1, int)
        np.add.at(delta, i0, 1)
        np.add.at(delta, i1, -1)
        on = (np.cumsum(delta)[:-1] > 0).astype(np.uint8)
    return ({"storey": storey, "on_stairs": on},
            {"building_plan": json.dumps(plan.to_attrs()), "building_axis_rad": float(plan.axis_rad)})


__all__ = ["BUILDING", "Plan", "draw_plan", "building", "plan_truth"]
