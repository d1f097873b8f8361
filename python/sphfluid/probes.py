"""Measurement probes: the scene's ``"probes"`` (an extension of the format).

Three kinds, each sampled from the particles by SPH interpolation with the
Wendland C2 kernel of the run's support h, volumes m / rho_j and Shepard
normalisation (docs/output.md, "Probes"):

- points: pressure, velocity and density at a fixed point;
- surface: the free-surface height along a vertical line x = X;
- walls: the pressure and viscous forces of the fluid on a group of wall segments, per
  metre of depth.

``sample(sim, probes)`` returns one dict of values for the current state;
``ProbeWriter`` appends them as rows of a CSV file while a run goes.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

# Below this kernel sum sum_j V_j W(x - x_j) a point has too little fluid around it
# for an interpolated value: it is in air, or at the outer edge of a free surface
# (a flat surface's sum is 0.5 on the surface itself).
MIN_KERNEL_SUM = 0.5
# Query points times particles per block of the brute-force interpolation.
_BLOCK = 2_000_000

POINT_COLUMNS = ("p", "u", "v", "rho")  # Pa, m/s, m/s, kg/m^3
SURFACE_COLUMNS = ("height",)  # m
WALL_COLUMNS = ("fx", "fy", "fx_viscous", "fy_viscous")  # N/m: pressure and viscous parts


@dataclass(frozen=True)
class PointProbe:
    name: str
    at: tuple  # (x, y), m


@dataclass(frozen=True)
class SurfaceProbe:
    name: str
    x: float  # the vertical line x = X, m


@dataclass(frozen=True)
class WallProbe:
    name: str
    segments: tuple  # indices into Scene.walls (polylines counted segment by segment)


@dataclass(frozen=True)
class Probes:
    points: tuple = ()  # of PointProbe
    surface: tuple = ()  # of SurfaceProbe
    walls: tuple = ()  # of WallProbe
    every: float | None = None  # s between rows; None: the run's frame interval

    def to_dict(self) -> dict:
        out: dict[str, Any] = {}
        if self.points:
            out["points"] = [{"name": p.name, "at": list(p.at)} for p in self.points]
        if self.surface:
            out["surface"] = [{"name": s.name, "x": s.x} for s in self.surface]
        if self.walls:
            out["walls"] = [{"name": w.name, "segments": list(w.segments)} for w in self.walls]
        if self.every is not None:
            out["every"] = self.every
        return out

    def columns(self) -> list[str]:
        """The CSV's columns after ``time``: name.quantity."""
        cols = [f"{p.name}.{q}" for p in self.points for q in POINT_COLUMNS]
        cols += [f"{s.name}.{q}" for s in self.surface for q in SURFACE_COLUMNS]
        cols += [f"{w.name}.{q}" for w in self.walls for q in WALL_COLUMNS]
        return cols


# --------------------------------------------------------------------------- validation

def read_probes(v, raw: dict, lo, hi, n_segments: int | None) -> Probes | None:
    """The scene's "probes", which the JSON Schema has checked, read with the
    scene validator ``v``: what the schema cannot say (unique names, inside the
    domain, segments that exist) as problems by JSON path; lo, hi: the domain's
    corners (None after a problem); n_segments: the walls' segment count (None
    after a problem). None after any problem."""
    if not v.ok("probes"):
        return None
    n_before = len(v.problems)
    names: dict[str, str] = {}  # name -> the path of the probe that has it

    def items(key: str):
        for i, item in enumerate(raw.get(key, [])):
            path = f"probes.{key}[{i}]"
            name = item["name"]
            if name in names:
                v.fail(f"{path}.name", f"{json.dumps(name)} is already the name of "
                       f"{names[name]}; probe names must be unique")
            names.setdefault(name, path)
            yield path, item, name

    points = []
    for path, item, name in items("points"):
        at = v.point(item, "at", path)
        if lo and hi and not (lo[0] <= at[0] <= hi[0] and lo[1] <= at[1] <= hi[1]):
            v.fail(f"{path}.at", f"{list(at)} is outside the domain (min {list(lo)}, "
                   f"max {list(hi)})")
        points.append(PointProbe(name, at))
    surface = []
    for path, item, name in items("surface"):
        x = float(item["x"])
        if lo and hi and not lo[0] <= x <= hi[0]:
            v.fail(f"{path}.x", f"{x:g} is outside the domain ({lo[0]:g} to {hi[0]:g})")
        surface.append(SurfaceProbe(name, x))
    walls = []
    for path, item, name in items("walls"):
        segs = tuple(int(s) for s in item["segments"])
        for j, s in enumerate(segs):
            if n_segments is not None and s >= n_segments:
                v.fail(f"{path}.segments[{j}]", f"no segment {s}: the walls have "
                       f"{n_segments} segment(s), numbered from 0 (a polyline counts one "
                       "per segment)")
        walls.append(WallProbe(name, segs))
    every = v.number(raw, "every", "probes.")
    if len(v.problems) > n_before:
        return None
    if not (points or surface or walls):
        v.fail("probes", 'has no probe: give "points", "surface" or "walls"')
        return None
    return Probes(tuple(points), tuple(surface), tuple(walls), every)


# --------------------------------------------------------------------------- sampling

def wendland(r: np.ndarray, h: float) -> np.ndarray:
    """The Wendland C2 kernel in 2D with support h: 7/(pi h^2) (1 - q)^4 (1 + 4q), q = r/h."""
    q = np.minimum(r * (1.0 / h), 1.0)
    w = 1.0 - q  # (in place: the surface's grids call it on millions of distances)
    w *= w
    w *= w
    w *= 1.0 + 4.0 * q
    w *= 7.0 / (np.pi * h * h)
    return w


class _Field:
    """The particles' state, interpolated at query points."""

    def __init__(self, sim):
        self.pos = np.asarray(sim.positions, float)
        self.vel = np.asarray(sim.velocities, float)
        self.rho = np.asarray(sim.densities, float)
        self.p = np.asarray(sim.pressures, float)
        self.vol = sim.particle_mass / self.rho  # m^2 per m of depth
        self.h = float(sim.smoothing_length)

    def at(self, pts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(kernel sum (n,), Shepard-normalised [p, u, v, rho] (n, 4)) at points (n, 2);
        the values are NaN where the kernel sum is below MIN_KERNEL_SUM."""
        pts = np.asarray(pts, float).reshape(-1, 2)
        n, h = len(pts), self.h
        total = np.zeros(n)
        sums = np.zeros((n, 4))
        if n and len(self.pos):
            lo, hi = pts.min(0) - h, pts.max(0) + h  # the particles that can be in reach
            near = np.flatnonzero(np.all((self.pos >= lo) & (self.pos <= hi), axis=1))
            pos = self.pos[near]
            vals = np.column_stack([self.p[near], self.vel[near], self.rho[near]])
            vol = self.vol[near]
            step = max(1, _BLOCK // max(len(near), 1))
            for a in range(0, n, step):
                d = pts[a:a + step, None, :] - pos[None, :, :]
                w = wendland(np.sqrt((d * d).sum(-1)), h) * vol
                total[a:a + step] = w.sum(1)
                sums[a:a + step] = w @ vals
        with np.errstate(invalid="ignore", divide="ignore"):
            values = sums / total[:, None]
        values[total < MIN_KERNEL_SUM] = np.nan
        return total, values


def _surface_height(field: _Field, x: float, y0: float, y1: float, dx: float) -> float:
    """The highest y on x = X where the kernel sum crosses MIN_KERNEL_SUM from
    above, linearly interpolated between samples dx/4 apart; NaN with no fluid."""
    ys = np.linspace(y0, y1, max(2, int(math.ceil((y1 - y0) / (dx / 4))) + 1))
    c, _ = field.at(np.column_stack([np.full_like(ys, x), ys]))
    inside = c >= MIN_KERNEL_SUM
    if not inside.any():
        return math.nan
    k = int(np.flatnonzero(inside)[-1])
    if k == len(ys) - 1:
        return float(ys[-1])  # fluid up to the top of the domain
    t = (c[k] - MIN_KERNEL_SUM) / (c[k] - c[k + 1])
    return float(ys[k] + t * (ys[k + 1] - ys[k]))


def _wall_force(field: _Field, segments: np.ndarray, wall_velocity: np.ndarray, eta: float,
                dx: float) -> tuple[float, float, float, float]:
    """The force (N/m) of the fluid on the segments ((m, 2, 2), m), its pressure
    part and its viscous part, each summed over both sides of every segment.

    Pressure: F = -integral of p_wall n ds, n the side's normal, pointing into
    the fluid. p_wall at each station (midpoints of pieces about dx/2 long) is
    extrapolated linearly to the wall from the Shepard pressures h/2 and h off
    it along n: 2 p(h/2) - p(h). A side whose sample at h/2 is in air (kernel
    sum below MIN_KERNEL_SUM) has no fluid and adds nothing; where only the
    sample at h is (a film thinner than h), p(h/2) is taken as it is.

    Viscous: F = integral of eta du_t/dn t ds, t along the segment, u_t the
    fluid's velocity along t relative to the wall's own (wall_velocity, (m, 2)),
    its slope at the wall from a weighted least-squares fit u_t = a s + b s^2
    (s the distance from the wall, u_t = 0 on it: no slip) to the particles
    within h of the station on that side, weighted by the kernel; a side with
    fewer than 3 such particles adds nothing."""
    h = field.h
    fx = fy = vx = vy = 0.0
    for (a, b), u_wall in zip(segments, wall_velocity):
        t = b - a
        length = float(np.hypot(*t))
        pieces = max(1, int(math.ceil(length / (dx / 2))))
        s = (np.arange(pieces) + 0.5) / pieces
        stations = a + s[:, None] * t
        tangent = t / length
        normal = np.array([-t[1], t[0]]) / length
        ds = length / pieces
        for n in (normal, -normal):
            _, near = field.at(stations + 0.5 * h * n)
            _, far = field.at(stations + h * n)
            p_near, p_far = near[:, 0], far[:, 0]
            p_wall = np.where(np.isnan(p_far), p_near, 2.0 * p_near - p_far)
            force = -np.nansum(p_wall) * ds  # along n
            fx += force * n[0]
            fy += force * n[1]
            if eta > 0:
                shear = eta * np.nansum(_wall_slopes(field, stations, n, tangent, u_wall)) * ds
                vx += shear * tangent[0]
                vy += shear * tangent[1]
    return fx, fy, vx, vy


def _wall_slopes(field: _Field, stations: np.ndarray, n: np.ndarray, t: np.ndarray,
                 u_wall: np.ndarray) -> np.ndarray:
    """du_t/dn at the wall at each station on the side n (NaN where fewer than 3
    particles are in reach on that side): the slope a of the kernel-weighted
    least-squares fit u_t - u_wall.t = a s + b s^2 over the particles at
    distances s = (x_j - station).n in (0, h], within h of the station."""
    h = field.h
    lo, hi = stations.min(0) - h, stations.max(0) + h
    near = np.flatnonzero(np.all((field.pos >= lo) & (field.pos <= hi), axis=1))
    out = np.full(len(stations), np.nan)
    if len(near) == 0:
        return out
    pos, ut = field.pos[near], (field.vel[near] - u_wall) @ t
    step = max(1, _BLOCK // len(near))
    for k in range(0, len(stations), step):
        d = pos[None, :, :] - stations[k:k + step, None, :]
        sn = d @ n  # distance from the wall, (stations, particles)
        w = wendland(np.sqrt((d * d).sum(-1)), h) * (sn > 0)
        # normal equations of min sum w (a s + b s^2 - u)^2
        s2 = sn * sn
        m11, m12, m22 = (w * s2).sum(1), (w * s2 * sn).sum(1), (w * s2 * s2).sum(1)
        r1, r2 = (w * sn * ut).sum(1), (w * s2 * ut).sum(1)
        det = m11 * m22 - m12 * m12
        enough = ((w > 0).sum(1) >= 3) & (det > 1e-12 * m11 * m22)
        with np.errstate(invalid="ignore", divide="ignore"):
            out[k:k + step] = np.where(enough, (r1 * m22 - r2 * m12) / det, np.nan)
    return out


def sample(sim, probes: Probes | None = None) -> dict[str, float]:
    """The probes' values for sim's current state: {"time": t, "name.quantity": value}
    in the order of ``Probes.columns()``; probes default to the scene's.

    Points: p (Pa), u, v (m/s), rho (kg/m^3), NaN where the kernel sum is
    below MIN_KERNEL_SUM (air, or the edge of a free surface). Surface:
    height (m), NaN with no fluid on the line. Walls: fx, fy (N/m), the
    pressure force of the fluid on the group, and fx_viscous, fy_viscous its
    viscous (shear) force."""
    probes = probes if probes is not None else sim.scene.probes
    out: dict[str, float] = {"time": float(sim.time)}
    if probes is None:
        return out
    field = _Field(sim)
    scene = sim.scene
    if probes.points:
        _, vals = field.at(np.array([p.at for p in probes.points], float))
        for p, row in zip(probes.points, vals):
            for q, x in zip(POINT_COLUMNS, row):
                out[f"{p.name}.{q}"] = float(x)
    for s in probes.surface:
        out[f"{s.name}.height"] = _surface_height(field, s.x, scene.domain_min[1],
                                                  scene.domain_max[1], scene.spacing)
    if probes.walls:
        walls = np.asarray(sim.walls, float).reshape(-1, 2, 2)
        wall_velocity = np.zeros((len(walls), 2))
        if scene.wall_velocities and len(scene.wall_velocities) == len(walls):
            wall_velocity[:] = scene.wall_velocities
        for w in probes.walls:
            index = list(w.segments)
            forces = _wall_force(field, walls[index], wall_velocity[index], scene.viscosity,
                                 scene.spacing)
            for q, value in zip(WALL_COLUMNS, forces):
                out[f"{w.name}.{q}"] = float(value)
    return out


# --------------------------------------------------------------------------- the CSV

def probe_times(every: float, start: float, duration: float) -> list[float]:
    """The multiples of every in [start, duration] (start included only at t = 0)."""
    n = int(duration / every + 1e-9)
    return [t for k in range(0, n + 1) if (t := round(every * k, 12)) > start * (1 + 1e-12)
            or (start == 0 and k == 0)]


class ProbeWriter:
    """DIR/probes.csv of a run: comment lines ("# ") with the run metadata and the
    probes, the column names, then a row per probe time, flushed as written.

    ``due(t)``: whether the sample at simulated time t is the first at or past
    the next probe time; ``write(sim)`` writes its row. Resumed (start > 0), the
    file's rows after start are dropped and rows are appended."""

    def __init__(self, path: Path, sim, probes: Probes, every: float, duration: float):
        from .metadata import run_metadata
        from .output import replacing

        self.path = Path(path)
        self.probes = probes
        self.columns = ["time", *probes.columns()]
        start = float(sim.time)
        self.times = probe_times(every, start, duration)
        self.next = 0  # index into times of the next row due
        self.rows = 0  # written by this run
        if start > 0 and self.path.is_file():
            kept = [line for line in self.path.read_text(encoding="utf-8").splitlines(True)
                    if line.startswith("#") or line.startswith("time,")
                    or _row_time(line) <= start * (1 + 1e-12)]
            with replacing(self.path) as tmp:
                tmp.write_text("".join(kept), encoding="utf-8")
            self.file = open(self.path, "a", encoding="utf-8")  # noqa: SIM115
        else:
            self.file = open(self.path, "w", encoding="utf-8")  # noqa: SIM115
            self.file.write(f"# sphfluid probes: {json.dumps(run_metadata(sim))}\n")
            self.file.write(f"# probes: {json.dumps(probes.to_dict())}\n")
            self.file.write(f"# every: {every!r} s\n")
            self.file.write(",".join(self.columns) + "\n")
            self.file.flush()

    def due(self, t: float) -> bool:
        return self.next < len(self.times) and t >= self.times[self.next] * (1 - 1e-9)

    def write(self, sim) -> None:
        values = sample(sim, self.probes)
        self.file.write(",".join(repr(values[c]) for c in self.columns) + "\n")
        self.file.flush()
        self.rows += 1
        t = float(sim.time)
        while self.next < len(self.times) and t >= self.times[self.next] * (1 - 1e-9):
            self.next += 1

    def close(self) -> None:
        self.file.close()


def _row_time(line: str) -> float:
    try:
        return float(line.split(",", 1)[0])
    except ValueError:
        return math.inf


def read_csv(path) -> tuple[dict, list[str], np.ndarray]:
    """(the header's comments as {"metadata": ..., "probes": ..., "every": ...},
    the column names, the rows (n, columns)) of a probes.csv."""
    meta: dict[str, Any] = {}
    columns: list[str] = []
    rows = []
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        if line.startswith("# sphfluid probes: "):
            meta["metadata"] = json.loads(line.split(": ", 1)[1])
        elif line.startswith("# probes: "):
            meta["probes"] = json.loads(line.split(": ", 1)[1])
        elif line.startswith("# every: "):
            meta["every"] = float(line.split(": ", 1)[1].split()[0])
        elif line.startswith("time,"):
            columns = line.split(",")
        elif line and not line.startswith("#"):
            rows.append([float(x) for x in line.split(",")])
    return meta, columns, np.array(rows, float).reshape(-1, len(columns))
