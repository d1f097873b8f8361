"""Emitters, inlets, outlets, sinks, damping zones and moving walls: the scene's
``"emitters"``, ``"inlets"``, ``"outlets"``, ``"sinks"``, ``"damping_zones"`` and a
polyline's ``"motion"`` (extensions).

An emitter is a nozzle that emits a jet on the lattice of the scene's spacing:
rows of round(width / spacing) particles across, a new row whenever the last
has travelled one spacing, at a speed that is a constant or a table of
(time, speed) pairs, linear between them, from ``start`` to ``stop``. A sink
is a region (a rectangle, circle or polygon) that removes every particle
that enters it. The core applies both once a step after the drift, for every
method (``cpp/boundary/flows.hpp``), and counts what enters and what is sunk
(``Simulation.balance``). An inlet is an emitter whose rows start in a buffer
behind its line, ``buffer_depth`` deep, where they are held on the lattice at
the inflow's velocity, so the fluid beyond the line has its full kernel
support; an outlet is a line beyond which particles move straight out, at
their lane's mean speed before the line (held at rest where that is at rest
or flows back) and the reference pressure, through a buffer as deep, and
leave past its far side (counted as out). A wall's motion
moves it as a rigid body along tables of (time, value): its drawn position
translated and turned about a point; the core meets particles in each moving
wall's own frame, so none passes through it, and the boundary terms take
velocities relative to it. A damping zone slows the fluid beyond a line, more
the deeper in, so that waves end there without reflecting (a numerical beach).
docs/scene-format.md, "Emitters and sinks", "Inlets and outlets", "Damping zones"
and "Moving walls".
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

DEFAULT_DIRECTION = (0.0, -1.0)  # straight down


@dataclass(frozen=True)
class Emitter:
    """A nozzle centred at ``at``, ``width`` m across, emitting along ``direction``."""

    at: tuple  # (x, y), m
    direction: tuple = DEFAULT_DIRECTION  # any length; the core normalises it
    width: float | None = None  # m; None: one spacing (a single particle per row)
    speed: float | tuple = 1.0  # m/s, or ((t, speed), ...) in increasing t
    start: float = 0.0  # s
    stop: float | None = None  # s; None: never
    name: str = ""

    def table(self) -> tuple[list[float], list[float]]:
        """The speed as (times, speeds); a constant is one pair at t = 0."""
        if isinstance(self.speed, tuple):
            return [float(t) for t, _ in self.speed], [float(s) for _, s in self.speed]
        return [0.0], [float(self.speed)]

    def top_speed(self) -> float:
        return max(self.table()[1])

    def unit(self) -> np.ndarray:
        d = np.asarray(self.direction, float)
        return d / np.hypot(*d)

    def row(self, spacing: float) -> np.ndarray:
        """The positions (k, 2) of a row as it leaves the nozzle."""
        width = spacing if self.width is None else self.width
        count = max(1, round(width / spacing))
        d = self.unit()
        across = np.array([-d[1], d[0]])
        offsets = (np.arange(count) + 0.5 - 0.5 * count) * spacing
        return np.asarray(self.at, float) + offsets[:, None] * across

    def to_core(self, spacing: float, buffer: float = 0.0) -> dict:
        """As the core takes it; with buffer > 0 (m), an inlet's."""
        times, speeds = self.table()
        return {"at": list(self.at), "direction": list(self.direction),
                "width": spacing if self.width is None else self.width,
                "times": times, "speeds": speeds, "start": self.start,
                "stop": math.inf if self.stop is None else self.stop, "buffer": buffer}

    def zone(self, spacing: float, depth: float) -> np.ndarray:
        """The corners (4, 2) of the rectangle `depth` m behind the line (an
        inlet's buffer), around its particles' columns."""
        return _zone(self.at, -self.unit(), len(self.row(spacing)) * spacing, depth)

    def to_dict(self) -> dict:
        out: dict[str, Any] = {"at": list(self.at), "direction": list(self.direction)}
        if self.name:
            out = {"name": self.name, **out}
        if self.width is not None:
            out["width"] = self.width
        out["speed"] = ([list(p) for p in self.speed] if isinstance(self.speed, tuple)
                        else self.speed)
        if self.start:
            out["start"] = self.start
        if self.stop is not None:
            out["stop"] = self.stop
        return out


@dataclass(frozen=True)
class Outlet:
    """A line centred at ``at``, ``width`` m long, across ``direction`` (out of the fluid)."""

    at: tuple  # (x, y), m
    direction: tuple  # any length; the core normalises it
    width: float  # m
    name: str = ""
    level: float | None = None  # m along -g; None: the fluid's before the line

    def unit(self) -> np.ndarray:
        d = np.asarray(self.direction, float)
        return d / np.hypot(*d)

    def zone(self, depth: float) -> np.ndarray:
        """The corners (4, 2) of its buffer, `depth` m beyond the line."""
        return _zone(self.at, self.unit(), self.width, depth)

    def to_core(self, depth: float) -> dict:
        level = {} if self.level is None else {"level": self.level}
        return {"at": list(self.at), "direction": list(self.direction), "width": self.width,
                "depth": depth, **level}

    def to_dict(self) -> dict:
        out: dict[str, Any] = {"name": self.name} if self.name else {}
        level = {} if self.level is None else {"level": self.level}
        return {**out, "at": list(self.at), "direction": list(self.direction),
                "width": self.width, **level}


def _zone(at, unit, width: float, depth: float) -> np.ndarray:
    across = np.array([-unit[1], unit[0]]) * 0.5 * width
    at = np.asarray(at, float)
    far = at + depth * np.asarray(unit)
    return np.array([at - across, at + across, far + across, far - across])


def buffer_depth(spacing: float, h: float) -> float:
    """The depth of inlets' and outlets' buffers, m: two kernel supports h in
    whole spacings, so a particle within a support of the line has its own
    support full (the summation density's need; the fluid's is one support)."""
    return math.ceil(2.0 * h / spacing - 1e-9) * spacing


@dataclass(frozen=True)
class WallMotion:
    """A wall's rigid motion: its drawn points p are at about + (x, y)(t) +
    R(angle(t)) (p - about), each table linear between its times."""

    translation: tuple = ((0.0, 0.0, 0.0),)  # ((t, x, y), ...): s, m, m
    rotation: tuple = ((0.0, 0.0),)  # ((t, angle), ...): s, radians counterclockwise
    about: tuple = (0.0, 0.0)  # the centre of the rotation as drawn, m

    def times(self) -> list[float]:
        return sorted({row[0] for row in self.translation} | {row[0] for row in self.rotation})

    def top_speed(self, points) -> float:
        """The fastest any of these drawn points moves over the tables, m/s (the
        steepest translation plus the steepest turn times the farthest point)."""
        def steepest(rows, cols):
            return max((math.hypot(*[(q[c] - p[c]) / (q[0] - p[0]) for c in cols])
                        for p, q in zip(rows, rows[1:])), default=0.0)
        reach = max(math.dist(p, self.about) for p in points)
        return steepest(self.translation, (1, 2)) + steepest(self.rotation, (1,)) * reach

    def place(self, points, t: float) -> np.ndarray:
        """Where drawn points (k, 2) are at time t."""
        tt = [row[0] for row in self.translation]
        shift = np.array([np.interp(t, tt, [row[1] for row in self.translation]),
                          np.interp(t, tt, [row[2] for row in self.translation])])
        angle = np.interp(t, [row[0] for row in self.rotation], [row[1] for row in self.rotation])
        c, s = math.cos(angle), math.sin(angle)
        rel = np.asarray(points, float) - self.about
        return self.about + shift + rel @ np.array([[c, s], [-s, c]])

    def to_core(self) -> dict:
        return {"x": [[t, x] for t, x, _ in self.translation],
                "y": [[t, y] for t, _, y in self.translation],
                "angle": [list(r) for r in self.rotation], "about": list(self.about)}

    def to_dict(self) -> dict:
        out: dict[str, Any] = {}
        if self.translation != WallMotion.translation:
            out["translation"] = [list(r) for r in self.translation]
        if self.rotation != WallMotion.rotation:
            out["rotation"] = [list(r) for r in self.rotation]
            out["about"] = list(self.about)
        return out or {"translation": [[0.0, 0.0, 0.0]]}


def read_motion(v, item: dict, path: str, first_point) -> WallMotion | None:
    """A polyline's "motion" (the schema has checked its shape): tables whose
    times increase, by JSON path; None after a problem."""
    raw = item["motion"]
    rows = {}
    for key, width in (("translation", 3), ("rotation", 2)):
        table = tuple(tuple(float(x) for x in row) for row in raw.get(key, ()))
        for k in range(1, len(table)):
            if not table[k][0] > table[k - 1][0]:
                v.fail(f"{path}.motion.{key}[{k}]", f"its time {table[k][0]:g} s is not after "
                       f"the one before ({table[k - 1][0]:g} s): a table's times must increase")
                return None
        rows[key] = table or ((0.0,) * width,)
    about = v.point(raw, "about", f"{path}.motion.", tuple(map(float, first_point)))
    return WallMotion(rows["translation"], rows["rotation"], about)


def check_motions(v, walls: list, motions: list, paths: list, lo, hi,
                  dt: float | None = None, h: float | None = None) -> None:
    """Moving walls stay inside the domain: their ends at each table time (and
    halfway between, for a turn), by the wall's JSON path; with a fixed time step
    dt, none moves more than half the support h a step (the adaptive step keeps
    them within its CFL condition by itself)."""
    if dt and h:
        slow = set()
        for (a, b), m, path in zip(walls, motions, paths):
            if m is None or path in slow:
                continue
            speed = m.top_speed([a, b])
            if speed * dt > 0.5 * h:
                slow.add(path)
                v.fail(f"{path}.motion", f"moves the wall up to {speed:.3g} m/s, "
                       f"{speed * dt / h:.3g} supports a fixed step of {dt:g} s: at most "
                       f"half (a time step of at most {0.5 * h / speed:.3g} s, or "
                       '"time_step": "auto")')
    if not (lo and hi):
        return
    reported = set()
    for (a, b), m, path in zip(walls, motions, paths):
        if m is None or path in reported:
            continue
        times = m.times()
        times += [0.5 * (p + q) for p, q in zip(times, times[1:])]
        for t in sorted(times):
            ends = m.place([a, b], t)
            if not ((ends >= np.asarray(lo)).all() and (ends <= np.asarray(hi)).all()):
                reported.add(path)
                v.fail(f"{path}.motion", f"moves the wall outside the domain (min {list(lo)}, "
                       f"max {list(hi)}) by t = {t:g} s: keep it inside")
                break


def sink_to_core(region) -> dict:
    """A sink (a scene.Region) as the core takes it."""
    if region.shape == "circle":
        return {"centre": list(region.points[0]), "radius": region.radius}
    if region.shape == "rectangle":
        (x0, y0), (x1, y1) = region.points
        return {"polygon": [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]}
    return {"polygon": [list(p) for p in region.points]}


# --------------------------------------------------------------------------- validation

def read_emitters(v, raw: list, lo, hi, dx: float | None, walls: list,
                  key: str = "emitters", depth: float | None = None) -> list[Emitter]:
    """The scene's "emitters" (or, with key "inlets" and their buffers' depth,
    its inlets), which the JSON Schema has checked, read with the scene
    validator ``v``: what the schema cannot say as problems by JSON path (a
    zero direction, a speed table out of order, a stop before the start, a
    nozzle or an inlet's buffer outside the domain or crossed by a wall). lo,
    hi: the domain's corners and dx the spacing (None after a problem there)."""
    out = []
    for i, item in enumerate(raw):
        path = f"{key}[{i}]"
        if not (isinstance(item, dict) and v.ok(path)):
            continue
        n_before = len(v.problems)
        at = v.point(item, "at", path)
        direction = v.point(item, "direction", path, DEFAULT_DIRECTION)
        if not (math.isfinite(math.hypot(*direction)) and math.hypot(*direction) > 0):
            v.fail(f"{path}.direction", "must not be [0, 0]")
        speed = _speed(v, item["speed"], f"{path}.speed") if "speed" in item else 1.0
        start = v.number(item, "start", f"{path}.", 0.0)
        stop = v.number(item, "stop", f"{path}.")
        if stop is not None and not stop > start:
            v.fail(f"{path}.stop", f"must be after start ({start:g} s), got {stop:g}")
        width = v.number(item, "width", f"{path}.")
        if len(v.problems) > n_before or speed is None:
            continue
        e = Emitter(at=at, direction=direction, width=width, speed=speed, start=start,
                    stop=stop, name=str(item.get("name", "")))
        if dx and depth:
            _check_zone(v, e.zone(dx, depth), path, _buffer(depth), lo, hi, walls)
        elif dx:
            _check_nozzle(v, e, path, lo, hi, dx, walls)
        out.append(e)
    return out


def _speed(v, raw, path: str) -> float | tuple | None:
    """A speed: a number, or [[t, speed], ...] with t increasing."""
    if not isinstance(raw, list):
        return float(raw)
    pairs = tuple((float(t), float(s)) for t, s in raw)
    for k in range(1, len(pairs)):
        if not pairs[k][0] > pairs[k - 1][0]:
            v.fail(f"{path}[{k}]", f"its time {pairs[k][0]:g} s is not after the one before "
                   f"({pairs[k - 1][0]:g} s): a table's times must increase")
            return None
    return pairs


def read_outlets(v, raw: list, lo, hi, depth: float | None, walls: list) -> list[Outlet]:
    """The scene's "outlets" (the schema has checked their shape): a zero
    direction, a buffer outside the domain or crossed by a wall, by JSON path."""
    out = []
    for i, item in enumerate(raw):
        path = f"outlets[{i}]"
        if not (isinstance(item, dict) and v.ok(path)):
            continue
        at = v.point(item, "at", path)
        direction = v.point(item, "direction", path)
        width = v.number(item, "width", f"{path}.")
        if not (at and direction and width):
            continue
        if not (math.isfinite(math.hypot(*direction)) and math.hypot(*direction) > 0):
            v.fail(f"{path}.direction", "must not be [0, 0]")
            continue
        o = Outlet(at, direction, width, str(item.get("name", "")),
                   v.number(item, "level", f"{path}."))
        if depth:
            _check_zone(v, o.zone(depth), path, _buffer(depth), lo, hi, walls)
        out.append(o)
    return out


DEFAULT_DAMPING = 10.0  # 1/s at a damping zone's far end (DualSPHysics's default)


@dataclass(frozen=True)
class DampingZone:
    """Where waves end without reflecting: beyond the line through ``start``
    (across start -> end) each step keeps 1 - dt s^2 strength of a particle's
    velocity, s its distance past the line over |end - start| (1 beyond
    ``end``): Altomare et al. (2017)'s damping zone (cpp/boundary/damping.hpp).
    The scene's keys are "from" and "to"."""

    start: tuple  # (x, y), m: on the line where it begins
    end: tuple  # (x, y), m: where it reaches its full strength
    strength: float = DEFAULT_DAMPING  # 1/s
    name: str = ""

    def factor(self, points: np.ndarray, dt: float) -> np.ndarray:
        """The share of their velocity particles at ``points`` (n, 2) keep over dt."""
        axis = np.subtract(self.end, self.start)
        s = np.minimum((np.asarray(points, float) - self.start) @ axis / (axis @ axis), 1.0)
        return np.where(s > 0, np.maximum(1.0 - dt * s * s * self.strength, 0.0), 1.0)

    def region(self, lo, hi) -> np.ndarray:
        """The part of the domain [lo, hi] it covers, as a polygon (k, 2)."""
        box = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]], float)
        axis = np.subtract(self.end, self.start)
        side = (box - self.start) @ axis  # >= 0: inside
        out = []
        for k in range(4):  # the box clipped by the half-plane
            a, b, sa, sb = box[k], box[(k + 1) % 4], side[k], side[(k + 1) % 4]
            if sa >= 0:
                out.append(a)
            if (sa >= 0) != (sb >= 0):
                out.append(a + (b - a) * sa / (sa - sb))
        return np.array(out).reshape(-1, 2)

    def to_core(self) -> dict:
        return {"from": list(self.start), "to": list(self.end), "strength": self.strength}

    def to_dict(self) -> dict:
        out: dict[str, Any] = {"name": self.name} if self.name else {}
        out.update({"from": list(self.start), "to": list(self.end)})
        if self.strength != DEFAULT_DAMPING:
            out["strength"] = self.strength
        return out


def read_damping(v, raw: list, lo, hi) -> list[DampingZone]:
    """The scene's "damping_zones" (the schema has checked their shape): 'to'
    on 'from', a zone that covers none of the domain, by JSON path."""
    from .scene import _polygon_signed_area

    out = []
    for i, item in enumerate(raw):
        path = f"damping_zones[{i}]"
        if not (isinstance(item, dict) and v.ok(path)):
            continue
        start, end = v.point(item, "from", path), v.point(item, "to", path)
        strength = v.number(item, "strength", f"{path}.", DEFAULT_DAMPING)
        if not (start and end and strength):
            continue
        if not math.hypot(end[0] - start[0], end[1] - start[1]) > 0:
            v.fail(f"{path}.to", f"must differ from 'from' ({list(start)}): the two points give "
                   "the zone's direction and the length of its ramp")
            continue
        zone = DampingZone(start, end, float(strength), str(item.get("name", "")))
        area = abs(_polygon_signed_area(zone.region(lo, hi).tolist())) if lo and hi else None
        if area is not None and not area > 1e-12 * (hi[0] - lo[0]) * (hi[1] - lo[1]):
            v.fail(f"{path}.from", f"the zone (beyond {list(start)}, towards {list(end)}) "
                   "covers none of the domain: it would do nothing")
            continue
        out.append(zone)
    return out


def _buffer(depth: float) -> str:
    return f"its buffer ({depth:g} m deep: two kernel supports)"


def _check_zone(v, corners: np.ndarray, path: str, what: str, lo, hi, walls: list) -> None:
    """A buffer's rectangle inside the domain, no wall crossing its inside (walls
    along its sides are what a channel has)."""
    if lo and hi and not ((corners >= np.asarray(lo) - 1e-12).all()
                          and (corners <= np.asarray(hi) + 1e-12).all()):
        v.fail(path, f"{what} ({np.round(corners, 6).tolist()}) reaches outside the domain: "
               "its particles would be removed")
        return
    shrink = corners.mean(axis=0) + 0.999 * (corners - corners.mean(axis=0))
    for k, (p, q) in enumerate(walls):
        ends = np.array([p, q], float)
        if _in_rectangle(shrink, ends, 0.0) or any(
                _segments_cross(shrink[j], shrink[(j + 1) % 4], ends[0], ends[1])
                for j in range(4)):
            v.fail(path, f"a wall (segment {k}) crosses {what}: keep walls outside it or "
                   "along its sides")
            return


def check_buffers(v, inlets: list, outlets: list, dx: float, depth: float,
                  initial: np.ndarray | None, fluid: str = "the initial fluid",
                  paths: tuple[list[int], list[int]] | None = None) -> None:
    """No initial fluid in an inlet's or an outlet's buffer (an inlet facing out of
    the fluid, or an outlet inside it). ``fluid`` names the points (``initial``);
    ``paths`` the inlets' and outlets' indices in the scene (default 0, 1, ...)."""
    if initial is None or not len(initial):
        return
    for path, corners, kind in _buffer_zones(inlets, outlets, dx, depth, paths):
        what = ("faces out of the fluid: its buffer, behind the line, holds" if kind == "inlet"
                else "lies inside the fluid: its buffer holds")
        inside = _in_rectangle(corners, initial, 0.25 * dx)
        if inside:
            v.fail(path, f"{what} {inside} particle(s) of {fluid}; its direction "
                   "points into the domain's fluid for an inlet, out of it for an outlet")


def check_overlaps(v, inlets: list, outlets: list, dx: float, depth: float) -> None:
    """No two buffers (inlets' and outlets') overlapping by more than a quarter
    spacing: a particle in both would be held by both, and a lane counted twice."""
    zones = _buffer_zones(inlets, outlets, dx, depth)
    for b in range(len(zones)):
        for a in range(b):
            if _rectangles_overlap(zones[a][1], zones[b][1], 0.25 * dx):
                v.fail(zones[b][0], f"its buffer overlaps {zones[a][0]}'s: buffers must not "
                       "share particles (move one, or narrow it)")
                break


def _buffer_zones(inlets: list, outlets: list, dx: float, depth: float,
                  paths: tuple[list[int], list[int]] | None = None) -> list[tuple]:
    """(JSON path, the buffer's corners, "inlet" or "outlet") of each inlet and
    outlet; ``paths`` their indices in the scene (default 0, 1, ...)."""
    ins, outs = paths or (list(range(len(inlets))), list(range(len(outlets))))
    return ([(f"inlets[{k}]", e.zone(dx, depth), "inlet") for k, e in zip(ins, inlets)]
            + [(f"outlets[{k}]", o.zone(depth), "outlet") for k, o in zip(outs, outlets)])


def _rectangles_overlap(p: np.ndarray, q: np.ndarray, margin: float) -> bool:
    """Whether two rectangles (corners in order) overlap by more than margin along
    every axis of their sides (separating axes)."""
    for corners in (p, q):
        for j in range(2):
            edge = corners[j + 1] - corners[j]
            axis = np.array([-edge[1], edge[0]]) / np.hypot(*edge)
            a, b = p @ axis, q @ axis
            if min(a.max(), b.max()) - max(a.min(), b.min()) <= margin:
                return False
    return True


def _in_rectangle(corners: np.ndarray, points: np.ndarray, margin: float) -> int:
    """How many points lie inside the rectangle by more than margin."""
    origin, e1, e2 = corners[0], corners[1] - corners[0], corners[3] - corners[0]
    rel = points - origin
    s = rel @ e1 / (e1 @ e1)
    t = rel @ e2 / (e2 @ e2)
    m1, m2 = margin / np.sqrt(e1 @ e1), margin / np.sqrt(e2 @ e2)
    return int(((s > m1) & (s < 1 - m1) & (t > m2) & (t < 1 - m2)).sum())


def check_emitter_steps(v, emitters: list, dt: float | None, dx: float | None,
                        sound: float | None, key: str = "emitters") -> None:
    """Each jet slower than the fluid's speed of sound (when the scene gives one:
    the seed's sqrt(gas_constant), wcsph's fluid.speed_of_sound; by default wcsph
    takes 10 times the jets' speed), and with a fixed time step advancing at most
    a spacing a step (a row a step; the adaptive step follows the jet)."""
    for i, e in enumerate(emitters):
        if sound and e.top_speed() >= sound:
            v.fail(f"{key}[{i}].speed", f"{e.top_speed():g} m/s is not below the fluid's "
                   f"speed of sound, {sound:g} m/s: a weakly compressible fluid needs its "
                   "jets well below it (raise fluid.speed_of_sound or the gas constant)")
    if dt is None or not dx:
        return
    for i, e in enumerate(emitters):
        if e.top_speed() * dt > dx:
            v.fail(f"{key}[{i}].speed", f"{e.top_speed():g} m/s at the fixed time step "
                   f"{dt:g} s moves the jet {e.top_speed() * dt / dx:.3g} spacings a step: "
                   f"at most one (a time step of at most {dx / e.top_speed():.3g} s, or "
                   '"time_step": "auto")')


def _check_nozzle(v, e: Emitter, path: str, lo, hi, dx: float, walls: list) -> None:
    row = e.row(dx)
    if lo and hi and not ((row >= np.asarray(lo)).all() and (row <= np.asarray(hi)).all()):
        v.fail(path, f"its nozzle's row ({len(row)} particle(s) about {list(e.at)}) reaches "
               "outside the domain: its particles would be removed as they appear")
    a, b = row[0], row[-1]
    if len(row) == 1:  # a single particle: its own spacing across
        across = np.array([-e.unit()[1], e.unit()[0]]) * 0.5 * dx
        a, b = row[0] - across, row[0] + across
    for k, (p, q) in enumerate(walls):
        if _segments_cross(a, b, np.asarray(p), np.asarray(q)):
            v.fail(path, f"a wall (segment {k}) crosses its nozzle: move it clear of the walls")
            return


def _segments_cross(a, b, c, d) -> bool:
    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])
    d1, d2 = orient(c, d, a), orient(c, d, b)
    d3, d4 = orient(a, b, c), orient(a, b, d)
    return d1 * d2 <= 0 and d3 * d4 <= 0 and not (d1 == d2 == 0)


def check_sinks(v, sinks: list, lo, hi, initial: np.ndarray | None) -> None:
    """Sinks that meet the domain and hold none of the initial fluid (it would
    vanish in the first step)."""
    for i, s in enumerate(sinks):
        path = f"sinks[{i}]"
        (x0, y0), (x1, y1) = s.bounds()
        if lo and hi and (x1 < lo[0] or y1 < lo[1] or x0 > hi[0] or y0 > hi[1]):
            v.fail(path, f"lies outside the domain (min {list(lo)}, max {list(hi)}): it "
                   "removes nothing")
            continue
        if initial is not None and len(initial):
            held = int(s.contains(initial[:, 0], initial[:, 1], 0.0).sum())
            if held:
                v.fail(path, f"holds {held} particle(s) of the initial fluid, which would "
                       "vanish in the first step: keep sinks clear of fluid_regions")
