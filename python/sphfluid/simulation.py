"""Simulation: a Scene mapped onto the native solver, with numpy views of its state.

Adds no physics: every equation lives in the C++ core (``sphfluid._core``).
"""
from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import os
import threading
from typing import Callable

import numpy as np

from . import _core
from .flows import Emitter, sink_to_core
from .scene import AUTO_SHIFTING, Scene, SceneError, load_scene

InstabilityError = _core.InstabilityError
RETRIES = 5  # on_instability "retry": dt/2, dt/4, ... dt/32 before giving up


def expected_top_speed(scene: Scene) -> float:
    """The fastest the fluid is expected to move, m/s: free fall from the top of the
    fluid to the bottom of the domain, the regions' initial speeds, an emitter's jet
    falling from its nozzle to the bottom, the capillary speed sqrt(sigma / (rho0 dx)),
    and at least 0.1 m/s."""
    g = math.hypot(*scene.gravity)
    speeds = [0.1]
    lo, hi = scene.domain_min, scene.domain_max
    up = -np.asarray(scene.gravity) / g if g > 0 else np.zeros(2)
    bottom = min(float(np.dot(np.asarray(c), up)) for c in [lo, hi, (lo[0], hi[1]), (hi[0], lo[1])])
    if scene.regions and g > 0:
        top = max(float(np.dot(np.asarray(c), up)) for r in scene.regions
                  for c in r.bounds())
        speeds.append(math.sqrt(2 * g * max(top - bottom, 0.0)))
    speeds += [math.hypot(*r.velocity) for r in scene.regions]
    for e in (*scene.emitters, *scene.inlets):
        fall = max(float(np.dot(np.asarray(e.at), up)) - bottom, 0.0)
        speeds.append(math.sqrt(e.top_speed() ** 2 + 2 * g * fall))
    if scene.surface_tension > 0:
        speeds.append(math.sqrt(scene.surface_tension / (scene.rest_density * scene.spacing)))
    return max(speeds)


def speed_of_sound(scene: Scene) -> float:
    """wcsph's c0: the scene's, or 10 x the expected top speed (Mach 0.1, so density
    varies by about 1 %)."""
    if scene.speed_of_sound is not None:
        return scene.speed_of_sound
    return 10.0 * expected_top_speed(scene)


def _params(scene: Scene, threads: int | None) -> _core.SimParams:
    p = _core.SimParams()
    p.h = scene.smoothing_length
    p.rho0 = scene.rest_density
    p.method = _core.Method.__members__[scene.method]  # the registered methods' names
    if scene.method in ("wcsph", "dfsph"):  # dfsph: c0 bounds the guard's speeds only
        p.c0 = speed_of_sound(scene)
        p.alpha = scene.artificial_viscosity
        p.background_pressure = scene.background_pressure
        p.spacing = scene.spacing  # the walls mirror the particles' lattice
        if scene.particle_mass is not None:
            p.mass = scene.particle_mass
        elif scene.density == "continuity":  # the density is carried, not summed: a
            p.mass = scene.rest_density * scene.spacing**2  # particle's share of the area
        else:
            p.mass = _core.kernels.lattice_mass(scene.rest_density, scene.spacing,
                                                scene.smoothing_length, "wendland")
    else:
        p.mass = (scene.particle_mass if scene.particle_mass is not None
                  else _core.kernels.lattice_mass(scene.rest_density, scene.spacing,
                                                  scene.smoothing_length))
        p.k = scene.gas_constant
    p.eta = scene.viscosity
    p.sigma = scene.surface_tension
    p.gravity = scene.gravity
    p.domain_min = scene.domain_min
    p.domain_max = scene.domain_max
    p.periodic = scene.periodic
    p.restitution = scene.wall_restitution
    p.surface_threshold = -1.0 if scene.surface_threshold is None else scene.surface_threshold
    p.threads = 0 if threads is None else int(threads)
    p.cfl = scene.cfl
    p.float_pairs = scene.pair_precision == "float"
    p.continuity = scene.method == "wcsph" and scene.density == "continuity"
    if p.continuity:
        p.delta = scene.density_diffusion
        p.surface_pressure = scene.free_surface == "pressure_floor"  # W26b, else W26
        p.reconstruct_viscosity = bool(scene.viscosity_reconstruction)  # W30
        p.quintic_pressure = scene.pressure_kernel == "quintic"  # W31
        if scene.shifting == "auto":  # W21: only a flow with no free surface at its start
            p.shifting, p.shift_confined = AUTO_SHIFTING, True
        else:
            p.shifting = scene.shifting
    if scene.method == "dfsph":
        ps = scene.pressure_solve
        p.density_tolerance = ps.density_tolerance
        p.divergence_tolerance = ps.divergence_tolerance
        p.min_iterations = ps.min_iterations
        p.max_iterations = ps.max_iterations
        p.dt_max = ps.max_time_step
    # The guard bounds the surface energy by sigma x the regions' perimeters.
    p.surface_length = sum(r.perimeter() for r in scene.regions)
    p.max_retries = RETRIES if scene.on_instability == "retry" else 0
    return p


# The core takes a C int of steps per call: more are taken in calls of this many.
_STEPS_PER_CALL = 2**30


def count_argument(value, name: str) -> int:
    """value as a count (an integer >= 0; not a bool, not 1.5), or a clear error."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an integer, got {value!r}")
    if value < 0:
        raise ValueError(f"{name} must be >= 0, got {value}")
    return int(value)


def threads_argument(value) -> int | None:
    """A thread count as a Simulation takes it: None or 0 (OpenMP's default),
    else 1 up to 4 times the machine's cores (more only slows the step)."""
    if value is None:
        return None
    n = count_argument(value, "threads")
    cap = 4 * (os.cpu_count() or 1)
    if n > cap:
        raise ValueError(f"threads = {n} is more than 4 times this machine's "
                         f"{os.cpu_count()} cores: more threads than cores only slow the "
                         "step (0 or None: all cores)")
    return n


def _finite(value, name: str) -> float:
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{name} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"{name} must be finite, got {value!r}")
    return x


def _array(value, name: str, shape: tuple) -> np.ndarray:
    """value as a float array of ``shape`` (-1: any length), or a clear error."""
    want = "(" + ", ".join("n" if k < 0 else str(k) for k in shape) + ")"
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.size == 0 and len(shape) > 1:
        arr = arr.reshape((0,) + shape[1:])  # [] is no point, no wall
    if arr is None or arr.ndim != len(shape) or any(
            k >= 0 and k != m for k, m in zip(shape, arr.shape)):
        shown = repr(value) if len(repr(value)) < 80 else repr(value)[:77] + "..."
        raise ValueError(f"{name}: expected an array of shape {want} of numbers, got {shown}")
    return arr


def _one_thread(method):
    """A Simulation's method that changes it: refused with RuntimeError while
    another thread is inside one (a Simulation is used from one thread at a
    time; the same thread may nest them, as run() calls advance_to())."""
    @functools.wraps(method)
    def guarded(self, *args, **kwargs):
        if not self._busy.acquire(blocking=False):
            raise RuntimeError(f"{method.__name__}(): this Simulation is being changed by "
                               "another thread; use a Simulation from one thread at a time "
                               "(or one Simulation per thread)")
        try:
            return method(self, *args, **kwargs)
        finally:
            self._busy.release()
    return guarded


def _wall_array(scene: Scene) -> np.ndarray:
    if not scene.walls:
        return np.zeros((0, 2, 2))
    return np.asarray(scene.walls, dtype=float).reshape(-1, 2, 2)


class Simulation:
    """A running simulation of a scene with the scene's method (``seed``: docs/method-seed.md).

    The array properties (``positions``, ``velocities``, ``accelerations``,
    ``densities``, ``pressures``, ``ids``) are read-only numpy views of native
    memory, created on each access. Storage is re-sorted by grid cell every step,
    so a view shows the state at the time it was taken and is not updated by
    later steps: read the property again after stepping, and use ``ids`` to
    follow particles. ``copy()`` a view to modify it.
    """

    def __init__(self, scene: Scene | dict | str, *, threads: int | None = None):
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        self.scene = scene
        self._threads = threads_argument(threads)
        self._busy = threading.RLock()  # held by the thread inside a changing method
        self.reset()

    @_one_thread
    def reset(self) -> None:
        """Start again from the scene's initial particles at t = 0 (with wcsph's
        continuity density, compressed along gravity to their hydrostatic
        density: docs/method-wcsph.md, W23b)."""
        pos, vel = self.scene.lattice_points()
        self._solver = _core.Solver(_params(self.scene, self._threads), pos, vel,
                                    _wall_array(self.scene))
        self._solver.settle_fluid()  # wcsph's compressed start (method-wcsph.md, W23b)
        if self.scene.wall_velocities:  # sliding surfaces (docs/method-wcsph.md, W25)
            self._solver.set_wall_velocities(np.asarray(self.scene.wall_velocities, float))
        if self.scene.wall_motions:  # moving walls (flows.WallMotion)
            self._set_wall_motions()
        if self.scene.emitters or self.scene.sinks or self.scene.inlets or self.scene.outlets:
            self._set_flows()
        if self.scene.damping_zones:
            self._solver.set_damping([z.to_core() for z in self.scene.damping_zones])

    def _set_wall_motions(self) -> None:
        index: dict = {}  # each distinct motion once
        motion_of = [-1 if m is None else index.setdefault(m, len(index))
                     for m in self.scene.wall_motions]
        self._solver.set_wall_motions([m.to_core() for m in index], motion_of)

    def _set_flows(self, scene: Scene | None = None) -> None:
        """The core's emitters, inlets, sinks and outlets: the scene's (or those of
        ``scene``, a version of it)."""
        scene = scene or self.scene
        dx, depth = scene.spacing, scene.buffer_depth()
        self._solver.set_flows([e.to_core(dx) for e in scene.emitters]
                               + [e.to_core(dx, depth) for e in scene.inlets],
                               [sink_to_core(r) for r in scene.sinks], dx,
                               [o.to_core(depth) for o in scene.outlets])

    # -- stepping
    @property
    def adaptive(self) -> bool:
        """True when the scene asks for an adaptive time step ("auto")."""
        return self.scene.time_step is None

    @property
    def dt(self) -> float:
        """The time step, s: the scene's fixed one, or the last adaptive one."""
        if not self.adaptive:
            return self.scene.time_step
        return self._solver.last_dt

    @property
    def dt_limit(self) -> str:
        """What limited the last step: fixed, cfl, force, viscous or dt_max."""
        return self._solver.last_dt_limit

    @_one_thread
    def step(self, n: int = 1) -> None:
        """Advance n native steps (the GIL is released while they run).

        After every step a guard checks for non-finite values, a density over
        3 rho0, a speed over 10 times the speed of sound, and kinetic energy over
        twice what the scene can supply. A trip raises InstabilityError naming
        the step, the time, the particle, the check and the numbers, and leaves
        the state of the step before (unless the scene says
        "on_instability": "retry": then the step is retried with dt/2, dt/4, ...).
        """
        n = count_argument(n, "n")
        while n > 0:
            k = min(n, _STEPS_PER_CALL)
            if self.adaptive:
                self._solver.step_adaptive(k)
            else:
                self._solver.step(self.scene.time_step, k)
            n -= k

    @_one_thread
    def advance_to(self, t_end: float, max_steps: int | None = None) -> int:
        """Step until the simulated time reaches t_end, or max_steps were taken;
        returns the steps taken.

        Fixed steps stop at the first step at or past t_end; adaptive ones
        shorten the last step to land on it (so the end times a run stops at
        are part of its path; stopping after max_steps is not).
        """
        t_end = _finite(t_end, "t_end")
        limit = 2**62 if max_steps is None else count_argument(max_steps, "max_steps")
        if self.adaptive:
            return self._solver.advance_adaptive(float(t_end), limit)
        n = min(limit, max(0, math.ceil((t_end - self.time) / self.scene.time_step - 1e-9)))
        self.step(n)
        return n

    def _reached(self, t_end: float) -> bool:
        """Whether advance_to(t_end) would take no step: the run is at t_end (or,
        with fixed steps, at the first step at or past it)."""
        if self.adaptive:  # as Solver::advance_adaptive stops
            return not t_end - self.time > 1e-12 * max(1.0, abs(t_end))
        return math.ceil((t_end - self.time) / self.scene.time_step - 1e-9) <= 0

    @_one_thread
    def run(self, duration: float | None = None, progress: bool = False,
            callback: Callable[[Simulation], None] | None = None,
            every: float | None = None) -> None:
        """Advance by ``duration`` seconds (default: the scene's ``duration``).

        progress: show progress over simulated time on stderr (tqdm,
        sphfluid.progress). callback(sim) is called every ``every`` seconds of
        simulated time (and at the end) when given.
        """
        if duration is None:
            duration = self.scene.duration
        if duration is None:
            raise ValueError("no duration given and the scene has no 'duration'")
        if _finite(duration, "duration") < 0:
            raise ValueError(f"duration must be >= 0, got {duration}")
        if every is not None and not _finite(every, "every") > 0:
            raise ValueError(f"every must be > 0, got {every}")
        start = self.time
        chunk = every if every else duration / 100
        bar = None
        if progress:
            from .progress import Progress

            bar = Progress(start + duration, start, self.step_count)
        k = 0
        try:
            while k * chunk < duration * (1 - 1e-12):
                k += 1
                self.advance_to(start + min(k * chunk, duration))
                if bar:
                    bar.update(self.time, self)
                if callback:
                    callback(self)
        finally:
            if bar:
                bar.close()

    def instability_advice(self, error: BaseException | str) -> str:
        """What to change in the scene after ``error`` (an InstabilityError of
        this simulation): one line naming the settings and their values."""
        msg, s = str(error), self.scene
        tips = []
        if s.time_step is not None:
            tips.append(f'a smaller "solver.time_step" (now {s.time_step:g} s), or "auto" '
                        "for the largest stable one")
        else:
            tips.append(f'a smaller "solver.cfl" (now {s.cfl:g})')
        stiffness = ('"fluid.gas_constant"' if s.method == "seed" else
                     f'"fluid.speed_of_sound" (now {speed_of_sound(s):g} m/s)')
        if s.method == "dfsph":
            tips.append(f'a tighter "solver.density_tolerance" (now '
                        f'{s.pressure_solve.density_tolerance:g}) or more '
                        f'"solver.max_iterations" (now {s.pressure_solve.max_iterations})')
        elif "[check: density]" in msg:
            tips.append(f"a stiffer fluid, a larger {stiffness}")
        if s.method == "seed":
            tips.append(f'more "fluid.viscosity" (now {s.viscosity:g} Pa s; the seed\'s own '
                        'scenes run with 30-100), or "solver.method": "wcsph", which keeps '
                        "water stable")
        elif s.method == "wcsph" and ("[check: energy]" in msg or "[check: speed]" in msg
                                      or "[check: finite]" in msg):
            tips.append(f'more "fluid.artificial_viscosity" (now {s.artificial_viscosity:g})')
        if s.on_instability == "stop":
            tips.append('"solver.on_instability": "retry", which retries a tripped step with '
                        "halved time steps")
        return "what to change: " + "; ".join(tips)

    @_one_thread
    def compute_forces(self) -> None:
        """Density, pressure and acceleration for the current state; nothing moves."""
        self._solver.compute_forces()

    @_one_thread
    def set_state(self, positions, velocities, ids=None) -> None:
        """Replace all particles (N may change). ids default to 0..N-1; given,
        they must be distinct integers >= 0 (ValueError otherwise). An inlet's or
        outlet's buffer the new particles leave empty is filled again, as at the
        start (counted in ``balance``); one they hold particles in keeps them."""
        if ids is not None:
            given = np.asarray(ids)
            if given.size and not np.issubdtype(given.dtype, np.integer):
                raise ValueError(f"ids must be integers, got an array of {given.dtype}")
            ids = given.astype(np.int64).reshape(-1)
            if ids.size and ids.min() < 0:
                raise ValueError(f"ids must be >= 0, got {int(ids.min())}")
            if np.unique(ids).size != ids.size:
                raise ValueError("ids must be distinct: some repeat")
        self._solver.set_state(_array(positions, "positions", (-1, 2)),
                               _array(velocities, "velocities", (-1, 2)), ids)

    # -- editing (the viewer's terrain tools use these)
    @_one_thread
    def add_particles(self, positions, velocities=None) -> None:
        """Append particles (n, 2) with fresh ids; any outside the domain are dropped
        (and counted as removed)."""
        pos = _array(positions, "positions", (-1, 2))
        vel = np.zeros_like(pos) if velocities is None else _array(velocities, "velocities",
                                                                  (-1, 2))
        self._solver.add_particles(pos, vel)

    @_one_thread
    def add_emitter(self, emitter: Emitter) -> None:
        """Add an emitter (``flows.Emitter``) to the scene; it emits from the next
        step on (from its start time). Raises SceneError naming what is wrong, the
        run unchanged."""
        self.set_emitters([*self.scene.emitters, emitter])

    @_one_thread
    def set_emitters(self, emitters) -> None:
        """Replace the scene's emitters (a sequence of ``flows.Emitter``); checked as
        a scene's (SceneError), effective from the next step. An emitter kept from
        before starts a new row a spacing from its last (its travel is reset). The
        run's speed of sound stays what the scene's start gave (wcsph: a jet faster
        than the fluid was expected to move compresses more; a scene file with the
        emitters in it accounts for them)."""
        data = self.scene.to_dict()
        data["emitters"] = [e.to_dict() for e in emitters]
        scene = load_scene(data)  # every check a scene file gets
        self.scene = dataclasses.replace(self.scene, emitters=scene.emitters)
        self._set_flows()

    @_one_thread
    def set_flows(self, *, sinks=None, inlets=None, outlets=None, damping_zones=None) -> None:
        """Replace the scene's sinks (``scene.Region``), inlets (``flows.Emitter``),
        outlets (``flows.Outlet``) or damping zones (``flows.DampingZone``); those
        not given stay. Checked as a scene's, and a new inlet's or outlet's buffer
        against the fluid as it is now (it is filled at once): SceneError naming
        each problem by its JSON path, the run unchanged. Effective from the next
        step; an inlet or outlet kept unchanged keeps its buffer."""
        from .flows import check_buffers

        data = self.scene.to_dict()
        given = {"sinks": sinks, "inlets": inlets, "outlets": outlets,
                 "damping_zones": damping_zones}
        for key, items in given.items():
            if items is not None:
                data[key] = [x.to_dict() for x in items]
                if not data[key]:
                    del data[key]
        scene = load_scene(data)  # every check a scene file gets

        def shape(item) -> tuple:  # what keeps a buffer, as the core matches them
            return (tuple(item.at), tuple(np.round(item.unit(), 12)),
                    item.width or scene.spacing)

        kept_in = {shape(e) for e in self.scene.inlets}
        kept_out = {shape(o) for o in self.scene.outlets}
        new_in = [k for k, e in enumerate(scene.inlets) if shape(e) not in kept_in]
        new_out = [k for k, o in enumerate(scene.outlets) if shape(o) not in kept_out]
        if new_in or new_out:
            problems: list[str] = []

            class _Collect:
                def fail(self, path: str, msg: str) -> None:
                    problems.append(f"{path}: {msg}")

            check_buffers(_Collect(), [scene.inlets[k] for k in new_in],
                          [scene.outlets[k] for k in new_out], scene.spacing,
                          scene.buffer_depth(), self.positions, "the fluid now",
                          (new_in, new_out))
            if problems:
                raise SceneError(problems)
        self._set_flows(scene)
        self._solver.set_damping([z.to_core() for z in scene.damping_zones])
        self.scene = dataclasses.replace(self.scene, sinks=scene.sinks, inlets=scene.inlets,
                                         outlets=scene.outlets,
                                         damping_zones=scene.damping_zones)

    @property
    def balance(self) -> dict:
        """The particle count's balance: 'placed' (the scene's fluid, and what
        ``set_state`` and ``add_particles`` placed, less what they replaced), 'in'
        (emitters and inlets), 'out' (outlets), 'sunk', 'lost' (left the domain) and 'now';
        placed + in - out - sunk - lost = now, exactly. Times ``particle_mass``, the
        mass balance."""
        b = dict(self._solver.balance)
        return {"placed": b["placed"], "in": b["in"], "out": b["out"], "sunk": b["sunk"],
                "lost": b["lost"], "now": self.n_particles}

    @_one_thread
    def set_walls(self, walls) -> None:
        """Replace the walls: a sequence of segments ((x1, y1), (x2, y2)).

        Takes effect at once; the scene (what ``reset`` and saving use) follows.
        The new walls' surfaces are at rest (a sliding lid's velocity is dropped),
        and they stay where they are (a moving wall's motion is dropped).
        """
        arr = _array(walls, "walls", (-1, 2, 2))
        self._solver.set_walls(arr)  # validates: raises ValueError naming walls[i]
        segs = tuple((tuple(map(float, a)), tuple(map(float, b))) for a, b in arr)
        self.scene = dataclasses.replace(self.scene, walls=segs, wall_velocities=(),
                                         wall_motions=())

    @_one_thread
    def add_wall(self, a, b) -> None:
        """Add the wall segment a -> b (points [x, y], m)."""
        a, b = (tuple(_array(p, name, (2,))) for p, name in ((a, "a"), (b, "b")))
        self.set_walls([*self.scene.walls, (a, b)])

    @_one_thread
    def set_wall_motion(self, index: int, motion) -> None:
        """Give wall segment ``index`` a motion (``flows.WallMotion``, its tables
        in the run's time), or none (None): the segment as it is now becomes its
        drawn position, so it does not jump. Checked as a scene's (SceneError by
        JSON path, the run unchanged); effective at once."""
        walls = list(self.scene.walls)
        self._check_index(index, len(walls))
        motions = list(self.scene.wall_motions) or [None] * len(walls)
        walls[index] = tuple(tuple(map(float, p)) for p in self.walls[index])  # where it is
        motions[index] = motion
        moving = tuple(motions) if any(m is not None for m in motions) else ()
        data = self.scene.to_dict()
        data["walls"] = dataclasses.replace(self.scene, walls=tuple(walls),
                                            wall_motions=moving)._walls_json()
        scene = load_scene(data)  # every check a scene file gets
        self._solver.set_walls(np.asarray(scene.walls, float).reshape(-1, 2, 2))  # as drawn
        self.scene = dataclasses.replace(self.scene, walls=scene.walls,
                                         wall_velocities=scene.wall_velocities,
                                         wall_motions=scene.wall_motions)
        if scene.wall_velocities:
            self._solver.set_wall_velocities(np.asarray(scene.wall_velocities, float))
        if scene.wall_motions:
            self._set_wall_motions()  # placed at the run's time

    @staticmethod
    def _check_index(index, count: int) -> None:
        if isinstance(index, bool) or not isinstance(index, numbers.Integral):
            raise TypeError(f"index must be an integer, got {index!r}")
        if not -count <= index < count:
            raise IndexError(f"no wall {index}: there are {count}")

    @_one_thread
    def remove_wall(self, index: int) -> None:
        """Remove wall segment number ``index`` (as in ``walls``)."""
        walls = list(self.scene.walls)
        self._check_index(index, len(walls))
        del walls[index]
        self.set_walls(walls)

    # -- state
    @property
    def time(self) -> float:
        """Simulated time, s."""
        return self._solver.time

    @property
    def step_count(self) -> int:
        return self._solver.step_count

    @property
    def n_particles(self) -> int:
        return self._solver.n_particles

    @property
    def particle_mass(self) -> float:
        """kg per metre of depth."""
        return self._solver.params.mass

    @property
    def smoothing_length(self) -> float:
        """Kernel support h, m."""
        return self._solver.params.h

    @property
    def threads(self) -> int:
        """OpenMP threads the step may use (the constructor's ``threads``, or
        OpenMP's default). Below 1,000 particles the step runs on one thread
        whatever is set (see ``threads_in_use``)."""
        return self._solver.threads

    @threads.setter
    def threads(self, n: int) -> None:
        n = threads_argument(n)
        self._solver.threads = 0 if n is None else n

    @property
    def threads_in_use(self) -> int:
        """Threads the next step's loops use: ``threads``, or 1 while the scene
        has fewer than 1,000 particles. There the pair loops are one block,
        and a second thread's start and join cost more than it gains (seed
        dam break at 703 particles: 7,400 steps/s on 2 threads, 14,100 on 1)."""
        return self._solver.threads_in_use

    @property
    def positions(self) -> np.ndarray:
        """(N, 2) read-only view, m."""
        return self._solver.positions

    @property
    def velocities(self) -> np.ndarray:
        """(N, 2) read-only view, m/s."""
        return self._solver.velocities

    @property
    def accelerations(self) -> np.ndarray:
        """(N, 2) read-only view of the last force evaluation, m/s^2."""
        return self._solver.accelerations

    @property
    def densities(self) -> np.ndarray:
        """(N,) read-only view of the last evaluation, kg/m^3."""
        return self._solver.densities

    @property
    def pressures(self) -> np.ndarray:
        """(N,) read-only view of the last evaluation, Pa."""
        return self._solver.pressures

    @property
    def ids(self) -> np.ndarray:
        """(N,) stable particle ids (storage order changes every step)."""
        return self._solver.ids

    @property
    def walls(self) -> np.ndarray:
        """(S, 2, 2) copy of the wall segments, m."""
        return self._solver.walls

    @property
    def surface_energy(self) -> float:
        """wcsph with surface tension: the surface energy sigma x length of the
        state, J per m of depth (the tension is minus its gradient); 0 otherwise."""
        return self._solver.surface_energy

    @property
    def retried_steps(self) -> int:
        """Steps retried with a halved time step (on_instability: "retry")."""
        return self._solver.retried_steps

    @property
    def retry_log(self) -> list[str]:
        """What each recent retry was for, oldest first (at most 100)."""
        return list(self._solver.retry_log)

    @_one_thread
    def save_state(self, path) -> None:
        """Write a checkpoint of the current state (after a trip: the last good
        one) to path, an .npz file (sphfluid.checkpoint): ``load_state`` or
        ``Simulation.from_checkpoint`` continue from it bit for bit. Written under
        a temporary name and renamed into place."""
        from . import checkpoint

        checkpoint.save(self, path)

    @_one_thread
    def load_state(self, path) -> None:
        """Continue from a checkpoint written by ``save_state`` for this scene
        (sphfluid.checkpoint.CheckpointError, a ValueError, for another scene,
        another sphfluid version or a file that is not a checkpoint; the state
        is then unchanged)."""
        from . import checkpoint

        checkpoint.restore(self, path)

    @classmethod
    def from_checkpoint(cls, path, *, threads: int | None = None) -> Simulation:
        """A simulation of the scene a checkpoint holds, continued from it."""
        from . import checkpoint

        return checkpoint.load(path, threads=threads)

    @property
    def removed_particles(self) -> int:
        """Particles removed for leaving the domain."""
        return self._solver.removed_particles

    @property
    def wall_crossings(self) -> int:
        """Wall crossings the wall collisions stopped over the run: each time a
        particle's path would have crossed a wall in a step and was reflected
        (or stopped in front of it). The seed's walls work this way; with
        wcsph's wall forces it is a health counter, 0 while they hold the
        fluid off."""
        return self._solver.wall_crossings

    def density_extremes(self) -> tuple[float, float]:
        """(max |rho/rho0 - 1|, max(rho/rho0 - 1, 0)) of the current state: the
        density error (it counts the free surface's particles, whose summed
        density falls short for want of neighbours) and the compression; the
        two of ``stats()``, without its other sums."""
        rho = self.densities
        if not len(rho):
            return 0.0, 0.0
        lo, hi = float(rho.min()), float(rho.max())
        rho0 = self.scene.rest_density
        return max(abs(lo / rho0 - 1.0), abs(hi / rho0 - 1.0)), max(hi / rho0 - 1.0, 0.0)

    def stats(self) -> dict:
        """Summary numbers of the current state (SI units)."""
        v = self.velocities
        rho = self.densities
        speed2 = (v * v).sum(axis=1) if len(v) else np.zeros(0)
        max_err, max_comp = self.density_extremes()
        return {
            "time": self.time,
            "step_count": self.step_count,
            "dt": self.dt,
            "dt_limit": self.dt_limit,
            "method": self.scene.method,
            # the precision the seed's pair forces ran in (solver.pair_precision: "float"
            # runs where the cell clusters do, else "double")
            "pair_precision": "float" if self._solver.float_pairs else "double",
            # wcsph's continuity density: the kernel its last evaluation's pressure force
            # ran on ("quintic" where solver.pressure_kernel asks for it and the flow is
            # not shifted; W31), None for the other methods
            "pressure_kernel": (("quintic" if self._solver.quintic_pressure else "wendland")
                                if self.scene.method == "wcsph"
                                and self.scene.density == "continuity" else None),
            "n_particles": self.n_particles,
            "removed_particles": self.removed_particles,
            # particles in (emitters), out (outlets), sunk and lost (= removed_particles)
            **{f"particles_{k}": v for k, v in self.balance.items()
               if k in ("in", "out", "sunk", "lost")},
            "wall_crossings": self.wall_crossings,
            "kinetic_energy": 0.5 * self.particle_mass * float(speed2.sum()),  # J per m depth
            "max_speed": float(math.sqrt(speed2.max())) if len(v) else 0.0,
            "max_density_error": max_err,  # (density_extremes)
            "max_compression": max_comp,
            "mean_density_error": (float(np.abs(rho / self.scene.rest_density - 1.0).mean())
                                   if len(rho) else 0.0),
            "neighbour_pairs": self._solver.neighbour_pairs,
            "retried_steps": self.retried_steps,
            "energy_budget": self._solver.energy_budget,  # J per m depth, for the guard
            # J per m depth carried out of the domain by removed particles (the guard counts it)
            "energy_removed": self._solver.energy_removed,
            "surface_energy": self.surface_energy,  # J per m depth (wcsph with tension)
            # dfsph: the last step's iterations and mean errors of both solves (over rho0;
            # the divergence's over the step), and over the run the solves stopped at
            # max_iterations and the iterations taken (zeros for the other methods)
            **{f"solve_{k}": v for k, v in self._solver.solve_stats.items()},
        }
