"""Scene files (SCENE_FORMAT.md, ``sphfluid-scene/1``): loading, validation, particles.

``load_scene`` reads a JSON file or a dict, checks every key and value, and
returns a frozen :class:`Scene`. Every problem is collected and reported at
once with its JSON path in a :class:`SceneError`; nothing is simulated until
the scene is valid.
"""
from __future__ import annotations

import json
import math
import os
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from . import schema as _schema

FORMAT = _schema.scene_schema()["properties"]["format"]["const"]  # "sphfluid-scene/1"
METHODS = tuple(_schema.scene_schema()["properties"]["solver"]["properties"]["method"]["enum"])

# Defaults: the schema's ("default"), named here (units in the comments).
DEFAULT_GRAVITY = tuple(_schema.default("gravity"))  # m/s^2
DEFAULT_VISCOSITY = _schema.default("fluid", "viscosity")  # Pa s
DEFAULT_SURFACE_TENSION = _schema.default("fluid", "surface_tension")  # N (2D)
DEFAULT_ARTIFICIAL_VISCOSITY = _schema.default("fluid", "artificial_viscosity")  # wcsph alpha
DEFAULT_BACKGROUND_PRESSURE = _schema.default("fluid", "background_pressure")  # Pa
DEFAULT_PERIODIC = tuple(_schema.default("domain", "periodic"))
DEFAULT_CLOSED = False  # a polyline's "closed"
DEFAULT_VELOCITY = (0.0, 0.0)  # a region's or a wall surface's "velocity", m/s
DEFAULT_RESTITUTION = _schema.default("solver", "wall_restitution")  # mirror reflection
DEFAULT_CFL = _schema.default("solver", "cfl")  # CFL factor of the adaptive time step
ON_INSTABILITY = tuple(_schema.scene_schema()["properties"]["solver"]["properties"]
                       ["on_instability"]["enum"])  # the first is the default
PAIR_PRECISIONS = tuple(_schema.scene_schema()["properties"]["solver"]["properties"]
                        ["pair_precision"]["enum"])
# wcsph with continuity: delta (W18)
DEFAULT_DENSITY_DIFFUSION = _schema.default("solver", "density_diffusion")
# wcsph with continuity: the shifting coefficient k (W21), or "auto": AUTO_SHIFTING
# in a flow with no free surface at its start (a confined one), none in others
DEFAULT_SHIFTING = _schema.default("solver", "shifting")
DEFAULT_FREE_SURFACE = _schema.default("solver", "free_surface")
DEFAULT_VISCOSITY_RECONSTRUCTION = _schema.default("solver", "viscosity_reconstruction")
DEFAULT_PRESSURE_KERNEL = _schema.default("solver", "pressure_kernel")
QUINTIC_SUPPORT = 2.8  # W31's support in spacings (cpp/methods/wcsph/delta.cpp)
# The continuity density's solver keys with their defaults (Scene.to_dict writes a
# key where it differs).
CONTINUITY_DEFAULTS = {"shifting": DEFAULT_SHIFTING, "free_surface": DEFAULT_FREE_SURFACE,
                       "viscosity_reconstruction": DEFAULT_VISCOSITY_RECONSTRUCTION,
                       "pressure_kernel": DEFAULT_PRESSURE_KERNEL}
AUTO_SHIFTING = 8.0
DFSPH_KEYS = ("density_tolerance", "divergence_tolerance", "min_iterations", "max_iterations",
              "max_time_step")  # dfsph's solver keys (PressureSolve's fields)
DEFAULT_SMOOTHING_FACTOR = 2.0  # h = factor * spacing
CONTINUITY_SMOOTHING_FACTOR = 3.0  # wcsph with continuity: support over spacing
# Mueller et al. (2003): threshold l = 7.065 /m at h = 0.0457 m, so l h = 0.323.
DEFAULT_SURFACE_THRESHOLD_TIMES_H = 0.323

# Limits that keep a scene within this machine's means.
MAX_DOMAIN_CELLS = 50_000_000  # cells of size h over the domain (cell grid bound)
# wcsph's surface energy (docs/method-wcsph.md, eqs. W10-W12): its smallest h over dx, and
# the most nodes (16 bytes each) its lattice over the domain may need.
MIN_TENSION_SMOOTHING = 1.5
MAX_TENSION_NODES = 50_000_000
BYTES_PER_PARTICLE = 512  # state, sort scratch, neighbour lists, set-up temporaries
MAX_PARTICLES = 2**31 - 2  # particle indices are 32-bit in the core


def default_density(method: str, surface_tension: float | None, sliding: bool = False) -> str:
    """solver.density where a scene does not say: the continuity density for
    wcsph, but the summation with surface tension, whose pressures (sigma / R)
    are small enough for a carried density's drift to show (the validation
    droplet at 20 across: 13 % from Laplace's pressure, 1.1 % summed), unless
    a wall slides (which needs the continuity density); the seed's density
    is always summed."""
    if method != "wcsph" or (surface_tension and not sliding):
        return "summation"
    return "continuity"


class SceneError(ValueError):
    """A scene does not match the scene format; ``problems`` lists each one."""

    def __init__(self, problems: Sequence[str], source: str | None = None):
        self.problems = list(problems)
        self.source = source
        prefix = f"{source}: " if source else ""
        if len(self.problems) == 1:
            msg = prefix + self.problems[0]
        else:
            msg = f"{prefix}{len(self.problems)} problems:\n" + "\n".join(
                f"  {p}" for p in self.problems)
        super().__init__(msg)


Point = tuple  # (x, y), m


@dataclass(frozen=True)
class Region:
    """A shape filled with particles on the scene's lattice."""

    shape: str  # "rectangle" | "circle" | "polygon"
    points: tuple  # rectangle: (min, max); circle: (center,); polygon: vertices, m
    radius: float = 0.0  # circle radius, m
    velocity: Point = (0.0, 0.0)  # initial velocity, m/s

    def bounds(self) -> tuple[Point, Point]:
        if self.shape == "circle":
            (cx, cy), r = self.points[0], self.radius
            return (cx - r, cy - r), (cx + r, cy + r)
        xs = [p[0] for p in self.points]
        ys = [p[1] for p in self.points]
        return (min(xs), min(ys)), (max(xs), max(ys))

    def area(self) -> float:
        if self.shape == "rectangle":
            (x0, y0), (x1, y1) = self.points
            return (x1 - x0) * (y1 - y0)
        if self.shape == "circle":
            return math.pi * self.radius**2
        return abs(_polygon_signed_area(self.points))

    def perimeter(self) -> float:
        if self.shape == "rectangle":
            (x0, y0), (x1, y1) = self.points
            return 2 * ((x1 - x0) + (y1 - y0))
        if self.shape == "circle":
            return 2 * math.pi * self.radius
        return sum(math.dist(a, b) for a, b in _edges(self.points))

    def to_dict(self) -> dict:
        """As the scene format writes it (a velocity only when it is not zero)."""
        d: dict[str, Any] = {"shape": self.shape}
        if self.shape == "rectangle":
            d["min"], d["max"] = list(self.points[0]), list(self.points[1])
        elif self.shape == "circle":
            d["center"], d["radius"] = list(self.points[0]), self.radius
        else:
            d["points"] = [list(p) for p in self.points]
        if self.velocity != (0.0, 0.0):
            d["velocity"] = list(self.velocity)
        return d

    def contains(self, x: np.ndarray, y: np.ndarray, tol: float) -> np.ndarray:
        if self.shape == "rectangle":
            (x0, y0), (x1, y1) = self.points
            return (x >= x0 - tol) & (x <= x1 + tol) & (y >= y0 - tol) & (y <= y1 + tol)
        if self.shape == "circle":
            (cx, cy), r = self.points[0], self.radius
            return (x - cx) ** 2 + (y - cy) ** 2 <= (r + tol) ** 2
        return _inside_polygon(x, y, self.points)


@dataclass(frozen=True)
class PressureSolve:
    """dfsph's pressure solves (docs/method-dfsph.md): the tolerances as fractions
    of rho0 (the constant-density solve's mean density error; the divergence-free
    solve's mean density change over a step), each solve's least and most
    iterations, and the adaptive step's largest value."""

    density_tolerance: float = _schema.default("solver", "density_tolerance")
    divergence_tolerance: float = _schema.default("solver", "divergence_tolerance")
    min_iterations: int = _schema.default("solver", "min_iterations")
    max_iterations: int = _schema.default("solver", "max_iterations")
    max_time_step: float = _schema.default("solver", "max_time_step")  # s

    def to_dict(self) -> dict:
        """The keys that differ from the defaults, as the solver section writes them."""
        default = PressureSolve()
        return {k: getattr(self, k) for k in DFSPH_KEYS if getattr(self, k) != getattr(default, k)}


@dataclass(frozen=True)
class Scene:
    """A validated scene. Lengths in m, densities in kg/m^3, times in s."""

    domain_min: Point
    domain_max: Point
    rest_density: float  # rho0, kg/m^3
    gas_constant: float | None  # k, m^2/s^2 (seed)
    spacing: float  # lattice spacing dx, m
    smoothing_length: float  # kernel support h, m
    time_step: float | None  # dt, s; None: adaptive ("auto")
    name: str = ""
    gravity: Point = DEFAULT_GRAVITY  # m/s^2
    viscosity: float = DEFAULT_VISCOSITY  # eta, Pa s
    surface_tension: float = DEFAULT_SURFACE_TENSION  # sigma, N
    particle_mass: float | None = None  # kg per m of depth; None: lattice default
    regions: tuple = ()  # of Region
    walls: tuple = ()  # of ((x1, y1), (x2, y2)) segments, m
    # per segment, the velocity (u, v) of its surface along it (m/s; a sliding
    # lid); () when no wall's surface moves
    wall_velocities: tuple = ()
    # per segment, its flows.WallMotion or None (a fixed wall); () when none moves
    wall_motions: tuple = ()
    method: str = "seed"
    duration: float | None = None  # s
    wall_restitution: float = DEFAULT_RESTITUTION
    surface_threshold: float | None = None  # 1/m; None: 0.323 / h
    cfl: float = DEFAULT_CFL  # CFL factor of the adaptive step
    speed_of_sound: float | None = None  # wcsph c0, m/s; None: 10 x the expected top speed
    artificial_viscosity: float = DEFAULT_ARTIFICIAL_VISCOSITY  # wcsph alpha
    background_pressure: float = 0.0  # wcsph p_b, Pa (flows with no free surface)
    on_instability: str = "stop"  # "stop" | "retry" (halve dt, up to RETRIES times)
    pair_precision: str = "double"  # "float": the seed's pair forces in single precision
    density: str = "continuity"  # wcsph: "continuity" (W17-W31) or "summation" (W2)
    density_diffusion: float = DEFAULT_DENSITY_DIFFUSION  # wcsph with continuity: delta
    shifting: float | str = DEFAULT_SHIFTING  # wcsph with continuity: k (0: none) or "auto"
    # wcsph with continuity, at a free surface: "density_floor" (W26), "pressure_floor" (W26b)
    free_surface: str = DEFAULT_FREE_SURFACE
    viscosity_reconstruction: bool = DEFAULT_VISCOSITY_RECONSTRUCTION  # W30
    pressure_kernel: str = DEFAULT_PRESSURE_KERNEL  # W31
    pressure_solve: PressureSolve = PressureSolve()  # dfsph's solves
    periodic: tuple[bool, bool] = (False, False)  # the domain wraps along x / y
    probes: Any = None  # probes.Probes: measurement probes (extension), or None
    emitters: tuple = ()  # of flows.Emitter: nozzles emitting jets (extension)
    sinks: tuple = ()  # of Region: regions removing the particles entering them (extension)
    inlets: tuple = ()  # of flows.Emitter: lines fed from a held buffer (extension)
    outlets: tuple = ()  # of flows.Outlet: lines letting fluid out through a buffer (extension)
    damping_zones: tuple = ()  # of flows.DampingZone: where waves end (extension)
    source: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.method != "wcsph" and self.density != "summation":
            object.__setattr__(self, "density", "summation")  # the seed sums (SPEC.md)

    def _walls_json(self) -> list:
        """The walls as the scene format writes them: a sliding or moving wall's
        segment as {"polyline": [a, b], "velocity": [u, v]} or {..., "motion": {...}}."""
        out = []
        for k, (a, b) in enumerate(self.walls):
            v = self.wall_velocities[k] if self.wall_velocities else (0.0, 0.0)
            m = self.wall_motions[k] if self.wall_motions else None
            if any(v) or m is not None:
                d: dict[str, Any] = {"polyline": [list(a), list(b)]}
                if any(v):
                    d["velocity"] = list(v)
                if m is not None:
                    d["motion"] = m.to_dict()
                out.append(d)
            else:
                out.append([list(a), list(b)])
        return out

    def lattice_points(self) -> tuple[np.ndarray, np.ndarray]:
        """Positions (n, 2) and velocities (n, 2) of the initial particles.

        The lattice is global: points at ((i + 1/2) dx, (j + 1/2) dx). A point
        covered by several regions is created once, with the first region's
        velocity.
        """
        return _fill_regions(self.regions, self.spacing)

    def estimated_particles(self) -> int:
        return int(sum(r.area() for r in self.regions) / self.spacing / self.spacing)

    def to_dict(self) -> dict:
        """The scene as a JSON-ready dict that loads back to an equal Scene."""
        regions = [r.to_dict() for r in self.regions]
        out: dict[str, Any] = {
            "format": FORMAT,
            "name": self.name,
            "gravity": list(self.gravity),
            "domain": {"min": list(self.domain_min), "max": list(self.domain_max)},
            "fluid": {"rest_density": self.rest_density, "viscosity": self.viscosity,
                      "surface_tension": self.surface_tension},
            "resolution": {"spacing": self.spacing, "smoothing_length": self.smoothing_length},
            "fluid_regions": regions,
            "walls": self._walls_json(),
            "solver": {"method": self.method,
                       "time_step": "auto" if self.time_step is None else self.time_step,
                       "wall_restitution": self.wall_restitution},
        }
        if self.gas_constant is not None:
            out["fluid"]["gas_constant"] = self.gas_constant
        if self.speed_of_sound is not None:
            out["fluid"]["speed_of_sound"] = self.speed_of_sound
        if self.artificial_viscosity != DEFAULT_ARTIFICIAL_VISCOSITY:
            out["fluid"]["artificial_viscosity"] = self.artificial_viscosity
        if any(self.periodic):
            out["domain"]["periodic"] = list(self.periodic)
        if self.background_pressure:
            out["fluid"]["background_pressure"] = self.background_pressure
        if self.particle_mass is not None:
            out["resolution"]["particle_mass"] = self.particle_mass
        if self.surface_threshold is not None:
            out["solver"]["surface_threshold"] = self.surface_threshold
        if self.time_step is None:
            out["solver"]["cfl"] = self.cfl
        if self.on_instability != "stop":
            out["solver"]["on_instability"] = self.on_instability
        if self.pair_precision != "double":
            out["solver"]["pair_precision"] = self.pair_precision
        if self.method == "wcsph" and self.density != default_density(
                self.method, self.surface_tension, bool(self.wall_velocities)):
            out["solver"]["density"] = self.density
        if self.density_diffusion != DEFAULT_DENSITY_DIFFUSION:
            out["solver"]["density_diffusion"] = self.density_diffusion
        if self.method == "wcsph" and self.density == "continuity":
            for key, default in CONTINUITY_DEFAULTS.items():  # saved where they differ
                if getattr(self, key) != default:
                    out["solver"][key] = getattr(self, key)
        if self.method == "dfsph":
            out["solver"].update(self.pressure_solve.to_dict())
            if self.time_step is not None:
                out["solver"].pop("max_time_step", None)
        if self.duration is not None:
            out["duration"] = self.duration
        if self.probes is not None:
            out["probes"] = self.probes.to_dict()
        if self.emitters:
            out["emitters"] = [e.to_dict() for e in self.emitters]
        if self.sinks:
            out["sinks"] = [r.to_dict() for r in self.sinks]
        if self.inlets:
            out["inlets"] = [e.to_dict() for e in self.inlets]
        if self.outlets:
            out["outlets"] = [o.to_dict() for o in self.outlets]
        if self.damping_zones:
            out["damping_zones"] = [z.to_dict() for z in self.damping_zones]
        return out

    def buffer_depth(self) -> float:
        """The depth of the inlets' and outlets' buffers, m (flows.buffer_depth)."""
        from .flows import buffer_depth

        return buffer_depth(self.spacing, self.smoothing_length)


# --------------------------------------------------------------------------- loading

def load_scene(source: str | os.PathLike | Mapping[str, Any]) -> Scene:
    """Read and validate a scene from a JSON file path or an already-parsed dict.

    Raises SceneError naming every problem by its JSON path (and the file).
    """
    if isinstance(source, Mapping):
        return _Validator(dict(source), None).scene()
    if not isinstance(source, (str, os.PathLike)):  # parsed JSON that is not an object
        raise SceneError([f"expected a JSON object at the top level (or a file's path), got "
                          f"{_schema.kind(source)}"])
    path = Path(source)
    label = str(source)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise SceneError(["file not found"], label) from None
    except IsADirectoryError:
        raise SceneError(["is a directory, not a scene file"], label) from None
    except (OSError, UnicodeDecodeError) as e:
        raise SceneError([f"cannot read the file: {e}"], label) from None
    try:
        data = json.loads(text, object_pairs_hook=_no_duplicate_keys)
    except json.JSONDecodeError as e:
        raise SceneError([f"invalid JSON at line {e.lineno}, column {e.colno}: {e.msg}"],
                         label) from None
    except _DuplicateKey as e:
        raise SceneError([f"duplicate key {e.args[0]!r} in one JSON object"], label) from None
    except RecursionError:
        raise SceneError(["invalid JSON: arrays or objects nested too deeply"], label) from None
    except ValueError as e:  # an integer beyond Python's digit limit (4300)
        raise SceneError([f"invalid JSON: a number too long to read ({str(e).split(':')[0]})"],
                         label) from None
    if not isinstance(data, dict):
        raise SceneError([f"expected a JSON object at the top level, got {_schema.kind(data)}"], label)
    return _Validator(data, label).scene()


class _DuplicateKey(Exception):
    pass


def _no_duplicate_keys(pairs):
    out = {}
    for k, v in pairs:
        if k in out:
            raise _DuplicateKey(k)
        out[k] = v
    return out


class _Domain(NamedTuple):
    lo: Point | None  # lower corner, m; None after a problem
    hi: Point | None  # upper corner, m
    periodic: tuple[bool, bool]


class _Solver(NamedTuple):
    method: Any  # one of METHODS, or None after a problem
    dt: float | None  # s; None when adaptive or after a problem
    adaptive: bool
    cfl: float | None
    restitution: float | None
    on_instability: Any
    pair_precision: Any
    threshold: float | None  # 1/m
    density: Any
    density_diffusion: float | None
    shifting: float | str | None
    free_surface: str | None
    viscosity_reconstruction: bool | None
    pressure_kernel: str | None
    pressure_solve: PressureSolve


class _Fluid(NamedTuple):
    rho0: float | None  # kg/m^3
    k: float | None  # m^2/s^2
    eta: float | None  # Pa s
    sigma: float | None  # N
    c0: float | None  # m/s
    p_b: float | None  # Pa
    alpha: float | None


class _Resolution(NamedTuple):
    dx: float | None  # m
    h: float | None  # m
    mass: float | None  # kg per m of depth


class _Validator:
    """What the JSON Schema cannot say, on a scene the schema has checked.

    The schema's problems come first (``schema.problems``); this class then
    reads every value the schema accepted, fills the defaults, and checks the
    geometry, the comparisons between values and the memory a scene needs.
    A value at, above or below a path the schema refused reads as None, so
    one mistake is reported once. One method per section, then the checks
    that need several sections.
    """

    def __init__(self, data: dict, source: str | None):
        self.data = data
        self.source = source
        found = _schema.problems(data)
        self.problems: list[str] = [f"{path or '(top level)'}: {msg}" for path, msg in found]
        self.refused = [path for path, _ in found]

    def fail(self, path: str, message: str) -> None:
        self.problems.append(f"{path}: {message}")
        self.refused.append(path)

    def raise_problems(self) -> None:
        if self.problems:
            raise SceneError(self.problems, self.source)

    # -- the scene
    def scene(self) -> Scene:
        if any(msg.endswith(_schema.TOO_DEEP) for msg in self.problems):
            self.raise_problems()  # the schema was not checked: nothing else is read
        d = self.data
        name = self.value(d, "name", "", "")
        gravity = self.point(d, "gravity", "", DEFAULT_GRAVITY)
        domain = self.domain(self.section(d, "domain"))
        solver = self.solver(self.section(d, "solver"))
        fluid = self.fluid(self.section(d, "fluid"))
        walls = self.walls(self.items(d, "walls"))
        if solver.density is None:  # a sliding wall needs the continuity density
            solver = solver._replace(density=default_density(
                solver.method, fluid.sigma, bool(self.wall_velocities())))
        res = self.resolution(self.section(d, "resolution"), continuity=solver.method ==
                              "wcsph" and solver.density == "continuity")
        regions = [r for i, item in enumerate(self.items(d, "fluid_regions"))
                   if (r := self.region(item, f"fluid_regions[{i}]")) is not None]
        duration = self.number(d, "duration", "")
        probes = None
        if isinstance(d.get("probes"), dict):
            from .probes import read_probes

            n_segments = None if any(p.startswith("walls") for p in self.refused) else len(walls)
            probes = read_probes(self, d["probes"], domain.lo, domain.hi, n_segments)
        emitters, sinks, inlets, outlets = self.flows(d, domain, res, walls, solver, fluid)
        damping = []
        if "damping_zones" in d:
            from .flows import read_damping

            damping = read_damping(self, self.items(d, "damping_zones"), domain.lo, domain.hi)

        self.check_cell_grid(domain, res)
        self.check_periodic_extent(domain, res, solver.method, fluid.sigma)
        self.check_tension_lattice(domain, res, solver.method, fluid.sigma)
        self.check_pressure_kernel(res, solver)
        self.check_sliding_walls(solver)
        self.check_regions_inside(domain, regions)
        self.check_walls_near(domain, walls)
        if res.dx and regions and not self.problems:
            self.check_particle_budget(regions, res.dx)
        self.raise_problems()

        assert solver.adaptive or solver.dt is not None
        scene = Scene(domain_min=domain.lo, domain_max=domain.hi, rest_density=fluid.rho0,
                      gas_constant=fluid.k, spacing=res.dx, smoothing_length=res.h,
                      time_step=solver.dt, name=name, gravity=gravity, viscosity=fluid.eta,
                      surface_tension=fluid.sigma, particle_mass=res.mass,
                      regions=tuple(regions), walls=tuple(walls), method=solver.method,
                      wall_velocities=self.wall_velocities(),
                      wall_motions=self.wall_motions(domain, solver, res),
                      duration=duration, wall_restitution=solver.restitution,
                      surface_threshold=solver.threshold, cfl=solver.cfl,
                      on_instability=solver.on_instability, speed_of_sound=fluid.c0,
                      artificial_viscosity=fluid.alpha, periodic=domain.periodic,
                      background_pressure=fluid.p_b, pair_precision=solver.pair_precision,
                      density=solver.density, density_diffusion=solver.density_diffusion,
                      shifting=solver.shifting, free_surface=solver.free_surface,
                      viscosity_reconstruction=solver.viscosity_reconstruction,
                      pressure_kernel=solver.pressure_kernel,
                      pressure_solve=solver.pressure_solve,
                      probes=probes, emitters=tuple(emitters),
                      sinks=tuple(sinks), inlets=tuple(inlets), outlets=tuple(outlets),
                      damping_zones=tuple(damping), source=self.source)
        self.check_regions_hold_points(scene.regions, res.dx)
        if sinks or inlets or outlets:
            from .flows import check_buffers, check_overlaps, check_sinks

            check_overlaps(self, inlets, outlets, res.dx, scene.buffer_depth())
            initial = None if self.problems else scene.lattice_points()[0]
            check_sinks(self, sinks, domain.lo, domain.hi, initial)
            check_buffers(self, inlets, outlets, res.dx, scene.buffer_depth(), initial)
        self.raise_problems()
        return scene

    # -- the sections, in the order their problems are reported
    def domain(self, dom: dict) -> _Domain:
        lo = self.point(dom, "min", "domain.")
        hi = self.point(dom, "max", "domain.")
        if lo and hi and not (lo[0] < hi[0] and lo[1] < hi[1]):
            self.fail("domain", f"min must be below max in x and y, got min {list(lo)}, "
                      f"max {list(hi)}")
            lo = hi = None
        periodic = self.value(dom, "periodic", "domain.", DEFAULT_PERIODIC)
        return _Domain(lo, hi, tuple(periodic or DEFAULT_PERIODIC))

    def solver(self, solver: dict) -> _Solver:
        p = "solver."
        method = self.value(solver, "method", p, "seed")
        step = self.value(solver, "time_step", p)
        adaptive = step == "auto"
        dt = None if adaptive or step is None else float(step)
        density = self.value(solver, "density", p)
        if method != "wcsph":
            density = "summation"  # the seed's (SPEC.md)
        elif density is None and not ({"density", "density_diffusion", "shifting",
                                       "free_surface", "viscosity_reconstruction",
                                       "pressure_kernel"}
                                      & set(solver)):
            density = None  # default_density's, once the fluid is known
        else:
            density = density or "continuity"
        shifting = self.value(solver, "shifting", p, DEFAULT_SHIFTING)
        return _Solver(
            method, dt, adaptive,
            cfl=self.number(solver, "cfl", p, DEFAULT_CFL),
            restitution=self.number(solver, "wall_restitution", p, DEFAULT_RESTITUTION),
            on_instability=self.value(solver, "on_instability", p, ON_INSTABILITY[0]),
            pair_precision=self.value(solver, "pair_precision", p, PAIR_PRECISIONS[0]),
            threshold=self.number(solver, "surface_threshold", p),
            density=density,
            density_diffusion=self.number(solver, "density_diffusion", p,
                                          DEFAULT_DENSITY_DIFFUSION),
            shifting=shifting if isinstance(shifting, str) or shifting is None
            else float(shifting),
            free_surface=self.value(solver, "free_surface", p, DEFAULT_FREE_SURFACE),
            viscosity_reconstruction=self.value(solver, "viscosity_reconstruction", p,
                                                DEFAULT_VISCOSITY_RECONSTRUCTION),
            pressure_kernel=self.value(solver, "pressure_kernel", p, DEFAULT_PRESSURE_KERNEL),
            pressure_solve=self.pressure_solve(solver))

    def pressure_solve(self, solver: dict) -> PressureSolve:
        """dfsph's solver keys (the schema allows them with dfsph only)."""
        d = PressureSolve()
        values = {k: self.value(solver, k, "solver.", getattr(d, k)) for k in DFSPH_KEYS}
        values = {k: (getattr(d, k) if v is None else type(getattr(d, k))(v))
                  for k, v in values.items()}
        lo, hi = values["min_iterations"], values["max_iterations"]
        if isinstance(lo, int) and isinstance(hi, int) and hi < lo:
            self.fail("solver.max_iterations", f"must be >= min_iterations ({lo}), got {hi}")
        return PressureSolve(**values)

    def flows(self, d: dict, domain: _Domain, res: _Resolution, walls: list,
              solver: _Solver, fluid: _Fluid) -> tuple[list, list[Region], list, list]:
        """The emitters, sinks, inlets and outlets (extensions; flows.py)."""
        if not {"emitters", "sinks", "inlets", "outlets"} & set(d):
            return [], [], [], []
        from .flows import buffer_depth, check_emitter_steps, read_emitters, read_outlets

        depth = buffer_depth(res.dx, res.h) if res.dx and res.h else None
        sound = (math.sqrt(fluid.k) if solver.method == "seed" and fluid.k else fluid.c0)
        jets = {}
        for key in ("emitters", "inlets"):
            jets[key] = read_emitters(self, self.items(d, key), domain.lo, domain.hi, res.dx,
                                      walls, key, depth if key == "inlets" else None)
            check_emitter_steps(self, jets[key], solver.dt, res.dx, sound, key)
        sinks = [r for i, item in enumerate(self.items(d, "sinks"))
                 if (r := self.region(item, f"sinks[{i}]")) is not None]
        outlets = read_outlets(self, self.items(d, "outlets"), domain.lo, domain.hi, depth, walls)
        return jets["emitters"], sinks, jets["inlets"], outlets

    def fluid(self, fl: dict) -> _Fluid:
        p = "fluid."
        return _Fluid(
            rho0=self.number(fl, "rest_density", p),
            k=self.number(fl, "gas_constant", p),
            eta=self.number(fl, "viscosity", p, DEFAULT_VISCOSITY),
            sigma=self.number(fl, "surface_tension", p, DEFAULT_SURFACE_TENSION),
            c0=self.number(fl, "speed_of_sound", p),
            p_b=self.number(fl, "background_pressure", p, DEFAULT_BACKGROUND_PRESSURE),
            alpha=self.number(fl, "artificial_viscosity", p, DEFAULT_ARTIFICIAL_VISCOSITY),
        )

    def resolution(self, res: dict, continuity: bool = False) -> _Resolution:
        """The spacing, the support (by default 2 spacings; 3 for wcsph's continuity
        density, docs/method-wcsph.md) and the particle mass."""
        dx = self.number(res, "spacing", "resolution.")
        h = self.number(res, "smoothing_length", "resolution.")
        if h is not None and dx is not None and h <= dx:
            self.fail("resolution.smoothing_length",
                      f"must be > spacing ({dx:g}), got {h:g}: particles on the "
                      "lattice would not see their neighbours")
            h = None
        elif "smoothing_length" not in res and dx is not None:
            h = (CONTINUITY_SMOOTHING_FACTOR if continuity else DEFAULT_SMOOTHING_FACTOR) * dx
        return _Resolution(dx, h, self.number(res, "particle_mass", "resolution."))

    def region(self, item: Any, path: str) -> Region | None:
        """One fluid region; None if it has any problem."""
        if not (isinstance(item, dict) and self.ok(path)):
            return None
        shape = item["shape"]
        velocity = self.point(item, "velocity", f"{path}.", DEFAULT_VELOCITY)
        if shape == "rectangle":
            a, b = self.point(item, "min", path), self.point(item, "max", path)
            if not (a[0] < b[0] and a[1] < b[1]):
                self.fail(path, f"min must be below max in x and y, got min {list(a)}, "
                          f"max {list(b)}")
                return None
            return Region("rectangle", (a, b), velocity=velocity)
        if shape == "circle":
            return Region("circle", (self.point(item, "center", path),),
                          radius=float(item["radius"]), velocity=velocity)
        pts = self.polygon(item["points"], f"{path}.points")
        return Region("polygon", tuple(pts), velocity=velocity) if pts else None

    def polygon(self, raw: list, path: str) -> list[Point] | None:
        pts = [(float(x), float(y)) for x, y in raw]
        crossing = _self_intersection(pts)
        if crossing:
            i, j = crossing
            self.fail(path, f"polygon is not simple: edge {i} crosses edge {j}")
            return None
        if abs(_polygon_signed_area(pts)) <= 0:
            self.fail(path, "polygon has zero area")
            return None
        return pts

    def walls(self, raw: list) -> list[tuple[Point, Point]]:
        self._velocities: list[Point] = []  # one per segment
        self._moving_wall = ""  # the path of the first wall whose surface moves
        self._wall_paths: list[str] = []  # one per segment
        self._motions: list = []  # one per segment: its flows.WallMotion or None
        out: list[tuple[Point, Point]] = []
        for i, item in enumerate(raw):
            path = f"walls[{i}]"
            if not self.ok(path):
                continue
            motion = None
            if isinstance(item, dict):
                segs = self.polyline(item, path)
                v = self.surface_velocity(item, path, segs)
                if "motion" in item:
                    motion = self.wall_motion(item, path, any(v))
            else:
                segs = self.segment(item, path)
                v = (0.0, 0.0)
            out += segs
            self._velocities += [v] * len(segs)
            self._wall_paths += [path] * len(segs)
            self._motions += [motion] * len(segs)
        self._segments = out
        return out

    def wall_motion(self, item: dict, path: str, sliding: bool):
        """A polyline's "motion" (flows.read_motion); None after a problem."""
        from .flows import read_motion

        if sliding:
            self.fail(f"{path}.motion", 'a wall cannot both slide ("velocity") and move '
                      '("motion")')
            return None
        return read_motion(self, item, path, item["polyline"][0])

    def wall_motions(self, domain: _Domain, solver: _Solver, res: _Resolution) -> tuple:
        """Per segment, its motion; () when none moves. Checks they stay inside."""
        motions = getattr(self, "_motions", [])
        if not any(m is not None for m in motions):
            return ()
        from .flows import check_motions

        check_motions(self, self._segments, motions, self._wall_paths, domain.lo, domain.hi,
                      solver.dt, res.h)
        return tuple(motions)

    def polyline(self, item: dict, path: str) -> list[tuple[Point, Point]]:
        """The segments of {"polyline": [[x, y], ...], "closed": false}."""
        raw = item["polyline"]
        pts = [(float(x), float(y)) for x, y in raw]
        if item.get("closed", DEFAULT_CLOSED):
            pts = pts + [pts[0]]
        out = []
        for j in range(len(pts) - 1):
            if _zero_length(pts[j], pts[j + 1]):
                where = f"{path}.polyline[{j + 1}]" if j + 1 < len(raw) else f"{path}.closed"
                self.fail(where, "repeats the previous point (zero-length segment)")
            else:
                out.append((pts[j], pts[j + 1]))
        return out

    def surface_velocity(self, item: dict, path: str, segs: list) -> Point:
        """A polyline's "velocity" [u, v]: its surface slides along it (a lid)."""
        v = self.point(item, "velocity", f"{path}.", DEFAULT_VELOCITY)
        if not any(v):
            return (0.0, 0.0)
        speed = math.hypot(*v)
        for a, b in segs:
            t = (b[0] - a[0], b[1] - a[1])
            if abs(v[0] * t[1] - v[1] * t[0]) > 1e-9 * speed * math.hypot(*t):
                self.fail(f"{path}.velocity", "must be along the wall: its surface slides, the "
                          "wall stays where it is (a lid); moving walls are not supported yet")
                return (0.0, 0.0)
        self._moving_wall = self._moving_wall or f"{path}.velocity"
        return v

    def wall_velocities(self) -> tuple:
        """Per segment, its surface velocity; () when none moves."""
        moving = any(any(v) for v in getattr(self, "_velocities", []))
        return tuple(self._velocities) if moving else ()

    def check_sliding_walls(self, solver: _Solver) -> None:
        """A sliding wall's velocity enters wcsph's continuity density and dfsph
        (its viscosity's walls) only."""
        if getattr(self, "_moving_wall", "") and not (
                solver.method == "dfsph" or solver.method == "wcsph"
                and solver.density == "continuity"):
            self.fail(self._moving_wall, 'a wall\'s velocity needs "method": "wcsph" with '
                      '"density": "continuity" (docs/method-wcsph.md, W25), or "dfsph"')

    def segment(self, item: list, path: str) -> list[tuple[Point, Point]]:
        """[[x1, y1], [x2, y2]] as a list of one segment (none after a problem)."""
        a, b = (tuple(map(float, p)) for p in item)
        if _zero_length(a, b):
            self.fail(path, "segment has zero length")
            return []
        return [(a, b)]

    # -- checks across sections
    def check_cell_grid(self, domain: _Domain, res: _Resolution) -> None:
        """The cells of size h over the domain stay within the cell grid's bound."""
        lo, hi, h = domain.lo, domain.hi, res.h
        if not (lo and hi and h):
            return
        if res.dx and res.dx >= min(hi[0] - lo[0], hi[1] - lo[1]):
            self.fail("resolution.spacing", f"must be smaller than the domain "
                      f"({hi[0] - lo[0]:g} x {hi[1] - lo[1]:g} m), got {res.dx:g}")
            return
        if h > max(hi[0] - lo[0], hi[1] - lo[1]):
            self.fail("resolution.smoothing_length", f"must not exceed the domain's size "
                      f"({hi[0] - lo[0]:g} x {hi[1] - lo[1]:g} m), got {h:g}")
            return
        cells = ((hi[0] - lo[0]) / h) * ((hi[1] - lo[1]) / h)
        if cells > MAX_DOMAIN_CELLS:
            self.fail("domain", f"spans {cells:.3g} cells of the smoothing length "
                      f"{h:g} m, more than the {MAX_DOMAIN_CELLS:.0e} the cell grid allows; "
                      "shrink the domain to where the fluid can go")

    def check_periodic_extent(self, domain: _Domain, res: _Resolution, method: Any,
                              sigma: float | None) -> None:
        """A periodic axis is long enough for the kernel (and wcsph's colour field)."""
        lo, hi, h, dx = domain.lo, domain.hi, res.h, res.dx
        if not (lo and hi and h):
            return
        for axis, axis_name, extent in ((0, "x", "wide"), (1, "y", "high")):
            if not domain.periodic[axis]:
                continue
            length = hi[axis] - lo[axis]
            if length < 2 * h:
                self.fail("domain.periodic", f"a periodic {axis_name} axis needs a domain at "
                          f"least 2 smoothing lengths ({2 * h:g} m) {extent}, got "
                          f"{length:g} m")
            elif method == "wcsph" and sigma and dx and length < 4 * h + dx / 2:
                # docs/method-wcsph.md (W10): the colour field's support is 2 h
                self.fail("domain.periodic", f"with surface tension, wcsph needs a periodic "
                          f"{axis_name} axis at least 4 smoothing lengths plus half a spacing "
                          f"({4 * h + dx / 2:g} m) {extent}, got {length:g} m")

    def check_pressure_kernel(self, res: _Resolution, solver: _Solver) -> None:
        """W31's quintic spline reaches 2.8 spacings: the search's support must too;
        and it acts where nothing shifts."""
        if solver.pressure_kernel != "quintic":
            return
        if isinstance(solver.shifting, float) and solver.shifting > 0:
            self.fail("solver.pressure_kernel", f'"quintic" acts in a flow that is not '
                      f'shifted: with "shifting": {solver.shifting:g} the pressure stays on '
                      'the Wendland kernel (give "shifting": 0 or "auto"; '
                      "docs/method-wcsph.md, W31)")
        elif res.dx and res.h and res.h < QUINTIC_SUPPORT * res.dx * (1 - 1e-9):
            self.fail("solver.pressure_kernel", f'"quintic" needs a support h of at least '
                      f"{QUINTIC_SUPPORT:g} spacings (resolution.smoothing_length; "
                      f"{res.h / res.dx:.3g} given): its spline reaches that far "
                      "(docs/method-wcsph.md, W31)")

    def check_tension_lattice(self, domain: _Domain, res: _Resolution, method: Any,
                              sigma: float | None) -> None:
        """wcsph's surface energy: h of enough spacings, and a node lattice that fits."""
        lo, hi, h, dx = domain.lo, domain.hi, res.h, res.dx
        if not (method == "wcsph" and sigma and dx and h):
            return
        # docs/method-wcsph.md (W11): the surface energy is summed on nodes dx/2
        # apart over the fluid's bounding box, with a colour kernel of support 2 h.
        if h < MIN_TENSION_SMOOTHING * dx:
            self.fail("resolution.smoothing_length", f"with surface tension, wcsph needs "
                      f"h of at least {MIN_TENSION_SMOOTHING:g} spacings ({h / dx:.3g} "
                      "given): below that the fluid's own lattice ripple outweighs the "
                      "surface (docs/method-wcsph.md, W10-W12); 2 spacings is the default")
        elif lo and hi:
            nodes = ((hi[0] - lo[0] + 4 * h) / (dx / 2) + 1) * (
                (hi[1] - lo[1] + 4 * h) / (dx / 2) + 1)
            if nodes > MAX_TENSION_NODES:
                self.fail("domain", f"with surface tension, wcsph sums the surface energy "
                          f"on nodes half a spacing apart over the fluid's extent: this "
                          f"domain could need {nodes:.3g} of them, more than the "
                          f"{MAX_TENSION_NODES:.0e} allowed ({16 * MAX_TENSION_NODES / 1e9:g} "
                          "GB); shrink the domain to where the fluid can go")

    def check_regions_inside(self, domain: _Domain, regions: list[Region]) -> None:
        lo, hi = domain.lo, domain.hi
        if not (lo and hi):
            return
        for i, r in enumerate(regions):
            (x0, y0), (x1, y1) = r.bounds()
            if x0 < lo[0] or y0 < lo[1] or x1 > hi[0] or y1 > hi[1]:
                self.fail(f"fluid_regions[{i}]", "reaches outside the domain (its "
                          "particles there would be removed at once)")

    def check_walls_near(self, domain: _Domain, walls: list) -> None:
        """Every wall's ends within the domain grown by its own size on each side:
        walls farther out meet no particle (those leaving the domain are removed)
        and only cost the walls' lookup grid."""
        lo, hi = domain.lo, domain.hi
        if not (lo and hi):
            return
        w, h = hi[0] - lo[0], hi[1] - lo[1]
        reported = set()
        for (a, b), path in zip(walls, self._wall_paths):
            for x, y in (a, b):
                if not (lo[0] - w <= x <= hi[0] + w and lo[1] - h <= y <= hi[1] + h) \
                        and path not in reported:
                    reported.add(path)
                    self.fail(path, f"reaches [{x:g}, {y:g}], farther from the domain "
                              f"(min {list(lo)}, max {list(hi)}) than the domain's own "
                              "size: no particle can get there")

    def check_particle_budget(self, regions: list[Region], dx: float) -> None:
        n = sum(r.area() for r in regions) / dx / dx  # may be inf
        need = n * BYTES_PER_PARTICLE
        avail = _available_memory()
        if n > MAX_PARTICLES or (avail is not None and need > 0.8 * avail):
            have = f"{avail / 2**30:.1f} GiB available" if avail else "the 32-bit index limit"
            count = f"{int(n):,}" if n < 1e15 else f"{n:.3g}"
            self.fail("fluid_regions", f"would create about {count} particles "
                      f"(~{need / 2**30:.3g} GiB), more than memory allows ({have}); "
                      "increase resolution.spacing")

    def check_regions_hold_points(self, regions: Sequence[Region], dx: float) -> None:
        for i, r in enumerate(regions):
            pos, _ = _fill_regions((r,), dx)
            if len(pos) == 0:
                self.fail(f"fluid_regions[{i}]", f"holds no lattice point at spacing {dx:g} m "
                          "(the region is smaller than the spacing)")

    # -- readers: a value the schema accepted, or the default when absent
    def ok(self, path: str) -> bool:
        """No problem found at, above or below the JSON path."""
        return not any(_related(r, path) for r in self.refused)

    def value(self, obj: Any, key: str, prefix: str, default: Any = None) -> Any:
        """obj[key]; the default when absent, None after a problem there."""
        if not isinstance(obj, dict) or key not in obj:
            return default
        return obj[key] if self.ok(prefix + key) else None

    def number(self, obj: Any, key: str, prefix: str, default: float | None = None
               ) -> float | None:
        x = self.value(obj, key, prefix, default)
        return None if x is None else float(x)

    def point(self, obj: Any, key: str, prefix: str, default: Point | None = None
              ) -> Point | None:
        """obj[key] as (x, y); prefix ending in "." or naming the object."""
        prefix = prefix if prefix.endswith(".") or not prefix else prefix + "."
        p = self.value(obj, key, prefix, default)
        return None if p is None else (float(p[0]), float(p[1]))

    def section(self, d: dict, key: str) -> dict:
        """The object d[key], or {} when absent or refused."""
        value = d.get(key)
        return value if isinstance(value, dict) else {}

    def items(self, d: dict, key: str) -> list:
        """The list d[key], or [] when absent or refused."""
        value = d.get(key)
        return value if isinstance(value, list) else []


def _zero_length(a: Point, b: Point) -> bool:
    """A segment no longer than round-off on its coordinates (1e-12 of them, or of 1 m
    near the origin): the walls' normals and lookups would divide by ~0."""
    return math.hypot(b[0] - a[0], b[1] - a[1]) <= 1e-12 * max(1.0, *map(abs, a + b))


def _related(a: str, b: str) -> bool:
    """One JSON path is the other, or contains it."""
    if len(a) > len(b):
        a, b = b, a
    return b == a or b.startswith(a + ".") or b.startswith(a + "[")


def _available_memory() -> int | None:
    """Bytes of memory available to a new allocation (Linux), or None if unknown."""
    try:
        with open("/proc/meminfo", encoding="ascii") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


# --------------------------------------------------------------------------- geometry

def _polygon_signed_area(pts: Sequence[Point]) -> float:
    return 0.5 * sum(pts[i][0] * pts[(i + 1) % len(pts)][1] - pts[(i + 1) % len(pts)][0] * pts[i][1]
                     for i in range(len(pts)))


def _edges(pts: Sequence[Point]) -> Iterator[tuple[Point, Point]]:
    for i in range(len(pts)):
        yield pts[i], pts[(i + 1) % len(pts)]


def _orient(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The side of c from the line a -> b: 1 left, -1 right, 0 on it (rows of (k, 2))."""
    return np.sign((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1])
                   - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))


def _on_segment(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """c, collinear with a -> b, lies within its bounding box."""
    return np.all((np.minimum(a, b) <= c) & (c <= np.maximum(a, b)), axis=1)


def _segments_cross(p1, p2, q1, q2) -> np.ndarray:
    """Segments p1 -> p2 and q1 -> q2 (rows) touch or cross."""
    o1, o2 = _orient(p1, p2, q1), _orient(p1, p2, q2)
    o3, o4 = _orient(q1, q2, p1), _orient(q1, q2, p2)
    return (((o1 != o2) & (o3 != o4))
            | ((o1 == 0) & _on_segment(p1, p2, q1)) | ((o2 == 0) & _on_segment(p1, p2, q2))
            | ((o3 == 0) & _on_segment(q1, q2, p1)) | ((o4 == 0) & _on_segment(q1, q2, p2)))


_PAIRS_PER_BLOCK = 1 << 20  # candidate edge pairs tested at once


def _self_intersection(pts: Sequence[Point]) -> tuple[int, int] | None:
    """The first pair of edges (i < j, in order) of the closed polygon that touch or
    cross, neighbours aside; None for a simple polygon. Sweep and prune: the edges
    sorted by their left end, each tested against those that start before it ends
    (in x), and whose y ranges overlap; about n log n for a drawn shape."""
    p = np.asarray(pts, dtype=float)
    n = len(p)
    a, b = p, np.roll(p, -1, axis=0)  # edge i: a[i] -> b[i]
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    order = np.argsort(lo[:, 0], kind="stable")
    end = np.searchsorted(lo[order, 0], hi[order, 0], side="right")
    count = np.maximum(end - np.arange(n) - 1, 0)
    first = None
    done = 0
    while done < n:  # blocks of sorted edges with about _PAIRS_PER_BLOCK candidates
        stop = int(np.searchsorted(np.cumsum(count[done:]), _PAIRS_PER_BLOCK)) + done + 1
        stop = min(max(stop, done + 1), n)
        k = np.repeat(np.arange(done, stop), count[done:stop])
        offset = np.arange(len(k)) - np.repeat(np.cumsum(count[done:stop]) - count[done:stop],
                                               count[done:stop])
        e, f = order[k], order[k + 1 + offset]
        e, f = np.minimum(e, f), np.maximum(e, f)
        keep = ((lo[e, 1] <= hi[f, 1]) & (lo[f, 1] <= hi[e, 1])
                & (f != e + 1) & ~((e == 0) & (f == n - 1)))
        e, f = e[keep], f[keep]
        hit = _segments_cross(a[e], b[e], a[f], b[f])
        if hit.any():
            i = np.lexsort((f[hit], e[hit]))[0]
            pair = (int(e[hit][i]), int(f[hit][i]))
            first = pair if first is None or pair < first else first
        done = stop
    return first


def _inside_polygon(x: np.ndarray, y: np.ndarray, pts: Sequence[Point]) -> np.ndarray:
    """Even-odd rule, vectorised over the query points."""
    inside = np.zeros(x.shape, dtype=bool)
    for (x1, y1), (x2, y2) in _edges(pts):
        crosses = (y1 > y) != (y2 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_at = x1 + (y - y1) * (x2 - x1) / (y2 - y1)
        inside ^= crosses & (x < x_at)
    return inside


def _fill_regions(regions: Sequence[Region], dx: float) -> tuple[np.ndarray, np.ndarray]:
    tol = 1e-9 * dx
    keys, vels = [], []
    for r in regions:
        (x0, y0), (x1, y1) = r.bounds()
        i = np.arange(math.floor(x0 / dx - 0.5) - 1, math.ceil(x1 / dx - 0.5) + 2)
        j = np.arange(math.floor(y0 / dx - 0.5) - 1, math.ceil(y1 / dx - 0.5) + 2)
        ii, jj = np.meshgrid(i, j)
        ii, jj = ii.ravel(), jj.ravel()
        inside = r.contains((ii + 0.5) * dx, (jj + 0.5) * dx, tol)
        keys.append(np.stack([ii[inside], jj[inside]], axis=1))
        vels.append(np.broadcast_to(np.asarray(r.velocity, float), (int(inside.sum()), 2)))
    if not keys:
        return np.zeros((0, 2)), np.zeros((0, 2))
    allk = np.concatenate(keys)
    allv = np.concatenate(vels)
    _, first = np.unique(allk, axis=0, return_index=True)
    first.sort()
    pos = (allk[first] + 0.5) * dx
    return np.ascontiguousarray(pos, dtype=float), np.ascontiguousarray(allv[first], dtype=float)
