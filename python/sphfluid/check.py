"""The scene check before a run (`sphfluid check`, and the start of `run` and `view`).

A scene that loads is valid by the format; these checks look at what it will
do: the initial particles (``Scene.lattice_points``) against the domain, the
walls and each other, a fixed time step against the stability limit the
adaptive step would take at the start, and the size of the run. Each finding
is an error (the run would go wrong at once) or a warning, with the JSON path
of the place it concerns; the numbers are printed as information.

Everything is O(N) numpy over the initial particles; the wall distances are
all particles against one segment at a time.
"""
from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from .scene import BYTES_PER_PARTICLE, DEFAULT_CFL, Scene, _fill_regions

# The adaptive step's conditions (cpp/core/params.hpp, cpp/context.cpp choose_dt):
#   dt <= cfl l / (c + |v|max), dt <= VISCOUS_FACTOR l^2 rho0 / eta
# with the method's step length l and sound speed c (cpp/methods/registry.cpp).
VISCOUS_FACTOR = 0.125  # SimParams::kViscousFactor


@dataclass(frozen=True)
class Finding:
    level: str  # "error" | "warning"
    path: str  # JSON path of the place it concerns, e.g. "walls[3]"
    message: str

    def __str__(self) -> str:
        return f"{self.level}: {self.path}: {self.message}"


@dataclass(frozen=True)
class StepLimit:
    dt: float  # s: the largest stable step at the start
    limit: str  # "cfl" | "viscous": the condition that gives it
    why: str  # the condition with the scene's numbers


@dataclass
class Report:
    findings: list[Finding]
    info: list[str]  # lines of information: particles, memory, steps

    @property
    def errors(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "error"]

    @property
    def warnings(self) -> list[Finding]:
        return [f for f in self.findings if f.level == "warning"]


def step_limit(scene: Scene, cfl: float | None = None) -> StepLimit:
    """The time step the adaptive step would take at the start, as the core's
    choose_dt computes it, with the initial speeds for |v|max. The force
    condition needs the first accelerations (pressure forces included), so it
    is left out: the estimate is an upper bound of the core's."""
    if cfl is None:
        cfl = scene.cfl if scene.time_step is None else DEFAULT_CFL
    if scene.method == "dfsph":  # the flow's speed only, at most max_time_step
        length, cap = scene.smoothing_length / 2, scene.pressure_solve.max_time_step
        v0 = max((math.hypot(*r.velocity) for r in scene.regions), default=0.0)
        dt = min(cfl * length / v0, cap) if v0 > 0 else cap
        return StepLimit(dt, "cfl" if dt < cap else "dt_max",
                         f"cfl: {cfl:g} h/2 / |v|max with h/2 = {length:g} m, |v|max = "
                         f"{v0:g} m/s, at most solver.max_time_step = {cap:g} s (dfsph: no "
                         "speed of sound)")
    if scene.method == "wcsph":  # its Wendland kernel's smoothing length h/2, its c0
        from .simulation import speed_of_sound

        length, c, c_text = scene.smoothing_length / 2, speed_of_sound(scene), "c0"
        l_text = "h/2"
    else:  # the seed: the support h, c = sqrt(k) of p = k (rho - rho0)
        length, c, c_text = scene.smoothing_length, math.sqrt(scene.gas_constant), "sqrt(k)"
        l_text = "h"
    v0 = max((math.hypot(*r.velocity) for r in scene.regions), default=0.0)
    dt = cfl * length / (c + v0)
    out = StepLimit(dt, "cfl", f"cfl: {cfl:g} {l_text} / ({c_text} + |v|max) with "
                    f"{l_text} = {length:g} m, {c_text} = {c:.4g} m/s, |v|max = {v0:g} m/s")
    if scene.viscosity > 0:
        visc = VISCOUS_FACTOR * length**2 * scene.rest_density / scene.viscosity
        if visc < dt:
            out = StepLimit(visc, "viscous", f"viscous: {VISCOUS_FACTOR:g} {l_text}^2 rho0 / "
                            f"eta with {l_text} = {length:g} m, rho0 = "
                            f"{scene.rest_density:g} kg/m^3, eta = {scene.viscosity:g} Pa s")
    return out


def wall_paths(scene: Scene, raw: Mapping[str, Any] | None) -> list[str]:
    """The JSON path of each wall segment's entry in "walls" (a polyline is one
    entry of several segments), from the scene's JSON; "walls" by segment
    number when the JSON is not at hand."""
    paths: list[str] = []
    walls = raw.get("walls", []) if raw is not None else None
    if isinstance(walls, list):
        for i, item in enumerate(walls):
            if isinstance(item, dict):
                n = len(item.get("polyline", [])) - 1 + bool(item.get("closed", False))
            else:
                n = 1
            paths += [f"walls[{i}]"] * n
    if len(paths) != len(scene.walls):
        paths = [f"walls (segment {k})" for k in range(len(scene.walls))]
    return paths


def _distance_to_segment(pos: np.ndarray, a, b) -> np.ndarray:
    """Distances of the points pos (n, 2) to the segment a-b, or of one point
    (2,) to the segments a-b ((s, 2) each): numpy broadcasting."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    ab = b - a
    t = np.clip(((pos - a) * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    d = pos - a - t[..., None] * ab
    return np.hypot(d[..., 0], d[..., 1])


def check_scene(scene: Scene, raw: Mapping[str, Any] | None = None) -> Report:
    """The physical checks of a loaded scene (raw: its JSON, to name the walls)."""
    findings: list[Finding] = []
    info: list[str] = []
    dx = scene.spacing
    lo, hi = np.asarray(scene.domain_min), np.asarray(scene.domain_max)
    near = 0.5 * dx * (1 - 1e-6)  # a lattice row half a spacing from a wall is the norm

    # each region's own lattice points (the scene creates a shared point once)
    per_region = [_fill_regions((r,), dx)[0] for r in scene.regions]
    for i, pos in enumerate(per_region):
        keep = np.ones(len(pos), bool)
        for axis in range(2):
            if not scene.periodic[axis]:  # a periodic axis wraps them in
                keep &= (pos[:, axis] >= lo[axis]) & (pos[:, axis] <= hi[axis])
        if (out := int(len(pos) - keep.sum())):
            findings.append(Finding("error", f"fluid_regions[{i}]", f"{out:,} of its "
                                    f"{len(pos):,} particles start outside the domain: they "
                                    "would be removed at once"))

    keys = [np.round(pos / dx - 0.5).astype(np.int64) for pos in per_region]
    for j in range(len(keys)):
        for i in range(j):
            shared = _shared_rows(keys[i], keys[j])
            if shared:
                findings.append(Finding(
                    "warning", f"fluid_regions[{j}]", f"overlaps fluid_regions[{i}]: {shared:,} "
                    f"particle(s) closer than half a spacing to one of fluid_regions[{i}] (they "
                    f"are created once, with fluid_regions[{i}]'s velocity)"))

    pos, _ = scene.lattice_points()
    if scene.walls:
        paths = wall_paths(scene, raw)
        close: dict[str, np.ndarray] = {}
        for (a, b), path in zip(scene.walls, paths):
            hit = _distance_to_segment(pos, a, b) < near
            close[path] = close[path] | hit if path in close else hit
        for path, hit in close.items():
            if (n := int(hit.sum())):
                findings.append(Finding("warning", path, f"{n:,} fluid particle(s) within half a "
                                        f"spacing ({dx / 2:g} m) of the wall: they start "
                                        "overlapping it"))

    findings += wall_gaps(scene, raw)
    findings += support_findings(scene)
    if not any(scene.gravity):
        findings += [Finding("warning", f"outlets[{i}].level", "has no effect without gravity: "
                             "the outlet holds the reference pressure")
                     for i, o in enumerate(scene.outlets) if o.level is not None]

    limit = step_limit(scene)
    if scene.time_step is not None and scene.time_step > limit.dt:
        # above the sound speed's CFL 1 (or the viscous bound) the explicit step
        # cannot be stable; between it and the adaptive step's CFL it may run
        hard = step_limit(scene, cfl=1.0)
        if scene.time_step > hard.dt:
            findings.append(Finding(
                "error", "solver.time_step", f"{scene.time_step:g} s is above the stability "
                f"limit {hard.dt:.3g} s at the start ({hard.why}); use at most "
                f"{limit.dt:.2g} s (the adaptive step's, cfl {DEFAULT_CFL:g}), or \"auto\""))
        else:
            findings.append(Finding(
                "warning", "solver.time_step", f"{scene.time_step:g} s is above the adaptive "
                f"step's {limit.dt:.3g} s at the start ({limit.why}), within the stability "
                f"limit {hard.dt:.3g} s (cfl 1): it may run, with more density noise; "
                f"{limit.dt:.2g} s or \"auto\" is safe"))

    n = len(pos)
    info.append(f"particles    {n:,} (~{n * BYTES_PER_PARTICLE / 2**20:.1f} MiB at the "
                f"{BYTES_PER_PARTICLE} bytes per particle the loader budgets)")
    step_text = (f"fixed {scene.time_step:g} s" if scene.time_step is not None
                 else f"adaptive, cfl {scene.cfl:g}")
    info.append(f"time step    {step_text}; stability limit at the start {limit.dt:.3g} s "
                f"({limit.limit})")
    if scene.duration is not None:
        dt = scene.time_step if scene.time_step is not None else limit.dt
        steps_f = scene.duration / dt
        if not steps_f <= MAX_STEPS:  # also inf and NaN
            where = "solver.time_step" if scene.time_step is not None else "solver"
            findings.append(Finding("error", where, f"{steps_f:.3g} steps of {dt:.3g} s to "
                                    f"t = {scene.duration:g} s, more than the {MAX_STEPS:.0e} "
                                    "a run may take: a larger time step or a shorter duration"))
        elif scene.time_step is not None:
            steps = math.ceil(steps_f - 1e-9)
            info.append(f"steps        {steps:,} to t = {scene.duration:g} s")
        else:
            steps = math.ceil(steps_f - 1e-9)
            info.append(f"steps        about {steps:,} to t = {scene.duration:g} s at the "
                        "start's step limit (more if the flow speeds up)")
    else:
        info.append("steps        the scene has no duration")
    return Report(findings, info)


# The most steps a scene's run may take to its duration (a billion steps of the
# smallest scene take days here).
MAX_STEPS = 10**9
# A wall's free end closer than this (in spacings) to another wall is a gap; a wider
# one is taken as a deliberate opening (the terrain scene's catch slope stops 2.5
# spacings short of the wall, to drain into the basin).
GAP_SPACINGS = 2.0


def wall_gaps(scene: Scene, raw: Mapping[str, Any] | None = None) -> list[Finding]:
    """Warnings for narrow gaps between walls: a wall's free end (one no other
    segment starts or ends at) closer than GAP_SPACINGS spacings to another
    segment, without touching it. Particles are points reflected by the walls:
    any such gap lets fluid through, and one that narrow is more likely a
    container drawn with its ends apart than a deliberate opening."""
    walls = np.asarray(scene.walls, dtype=np.float64).reshape(-1, 2, 2)
    if len(walls) < 2:
        return []
    dx = scene.spacing
    ends = walls.reshape(-1, 2)  # segment k's ends are rows 2k, 2k + 1
    scale = max(1.0, float(np.abs(ends).max()))
    touch = 1e-9 * scale
    paths = wall_paths(scene, raw)
    # a free end is one no other segment has (a joint a hair apart is taken as
    # touching below: its gap is within `touch`)
    uses = Counter(map(tuple, ends.tolist()))
    out: list[Finding] = []
    reported: set[tuple[str, ...]] = set()
    for i, end in enumerate(ends):
        if uses[tuple(end.tolist())] > 1:
            continue  # joined to another segment (the loader refuses zero lengths)
        seg = i // 2
        dist = _distance_to_segment(end, walls[:, 0], walls[:, 1])
        dist[seg] = np.inf
        k = int(np.argmin(dist))
        gap = float(dist[k])
        if touch < gap < GAP_SPACINGS * dx:
            key = tuple(sorted((paths[seg], paths[k])))  # a gap between two, once
            if key in reported:
                continue
            reported.add(key)
            where = f"{paths[k]}" if paths[k] != paths[seg] else "itself"
            out.append(Finding(
                "warning", paths[seg], f"ends at ({end[0]:g}, {end[1]:g}), {gap:.3g} m "
                f"({gap / dx:.2g} spacings) from {where}: fluid leaks through a gap that "
                "narrow; join the ends (or close the polyline) if it should hold fluid"))
    return out


# dfsph's pressure solves need a support of 2 spacings (its default): below it
# the solves' matrix loses its grip on the lattice (measured with the
# validation's scenes at 1.5 / 1.75 / 2 spacings: the tank at rest 50 / 16 /
# 10 % off hydrostatic, and the basin's jet blows up at 1.5).
DFSPH_MIN_SUPPORT = 2.0


def support_findings(scene: Scene) -> list[Finding]:
    """A support the scene's method is known to fail with."""
    ratio = scene.smoothing_length / scene.spacing
    if scene.method == "dfsph" and ratio < DFSPH_MIN_SUPPORT * (1 - 1e-9):
        return [Finding(
            "warning", "resolution.smoothing_length",
            f"{scene.smoothing_length:g} m is {ratio:.3g} spacings, below the "
            f"{DFSPH_MIN_SUPPORT:g} dfsph needs: its pressure solves lose their hold (a tank at "
            "rest ends 16-50 % off hydrostatic at 1.75-1.5 spacings, a jet into a pool blows "
            f"up at 1.5); leave it out for dfsph's default, {DFSPH_MIN_SUPPORT:g} spacings")]
    return []


def run_time(scene: Scene, threads: int | None = None, budget: float = 0.25,
             max_steps: int = 200) -> tuple[str | None, Finding | None]:
    """A line estimating the run's wall time, from the scene's first steps timed
    (after 2 untimed ones: at least 5, up to max_steps, budget seconds or the
    end) times its steps to the end at the step size they took; and an error
    if those steps blew up. (None, None) without a duration."""
    import time

    from .simulation import InstabilityError, Simulation

    if scene.duration is None:
        return None, None
    sim = Simulation(scene, threads=threads)
    n, begin = 0, 0.0
    try:
        while sim.time < scene.duration * (1 - 1e-12) and (
                n < 7 or (n < max_steps + 2 and time.perf_counter() - begin < budget)):
            if n == 2:  # the first two touch the memory and start the thread pool
                begin = time.perf_counter()
            sim.step(1)
            n += 1
    except InstabilityError as e:
        return None, Finding("error", "solver", f"the run blows up in its first {n + 1} "
                             f"steps: {e}")
    if n <= 2:
        return None, None  # (a run of one or two steps)
    per_step = (time.perf_counter() - begin) / (n - 2)
    steps = math.ceil(max(scene.duration - sim.time, 0.0) / sim.dt - 1e-9) + sim.step_count
    took = "" if scene.time_step is not None else (
        f", at the {sim.dt:.3g} s step the adaptive step took (it shrinks as the flow "
        "speeds up)")
    return (f"run time     about {_duration(steps * per_step)} on {sim.threads_in_use} "
            f"thread(s): {steps:,} steps at {per_step * 1e3:.3g} ms each, timed over steps "
            f"3 to {n}{took}"), None


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 7200:
        return f"{seconds / 60:.3g} min"
    return f"{seconds / 3600:.3g} h"


def _shared_rows(a: np.ndarray, b: np.ndarray) -> int:
    """How many lattice points (integer rows (i, j)) a and b have in common."""
    if len(a) == 0 or len(b) == 0:
        return 0
    pack = lambda k: k[:, 0] * (1 << 32) + k[:, 1]  # noqa: E731  (|i|, |j| < 2^31)
    return int(np.intersect1d(pack(a), pack(b), assume_unique=True).size)
