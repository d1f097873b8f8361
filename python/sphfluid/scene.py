"""Scene files (SCENE_FORMAT.md, ``sphfluid-scene/1``): loading, validation, particles.

``load_scene`` reads a JSON file or a dict, checks every key and value, and
returns a frozen :class:`Scene`. Every problem is collected and reported at
once with its JSON path in a :class:`SceneError`; nothing is simulated until
the scene is valid.
"""
from __future__ import annotations

import difflib
import json
import math
import os
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

FORMAT = "sphfluid-scene/1"
METHODS = ("seed", "wcsph")

# Defaults, in one place (units in the comments).
DEFAULT_GRAVITY = (0.0, -9.81)  # m/s^2
DEFAULT_VISCOSITY = 0.0  # Pa s
DEFAULT_SURFACE_TENSION = 0.0  # N (2D)
DEFAULT_SMOOTHING_FACTOR = 2.0  # h = factor * spacing
DEFAULT_RESTITUTION = 1.0  # mirror reflection, as the seed paper describes
DEFAULT_CFL = 0.4  # CFL factor of the adaptive time step
DEFAULT_ARTIFICIAL_VISCOSITY = 0.1  # wcsph: Monaghan's alpha
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

# "$schema" (extension): the schema an editor validates the file against
# (`sphfluid schema` prints it); the loader ignores its value.
_TOP_KEYS = ("$schema", "format", "name", "gravity", "domain", "fluid", "resolution",
             "fluid_regions", "walls", "solver", "duration", "probes")
_DOMAIN_KEYS = ("min", "max", "periodic")
_FLUID_KEYS = ("rest_density", "gas_constant", "viscosity", "surface_tension",
               "speed_of_sound", "artificial_viscosity", "background_pressure")
_RESOLUTION_KEYS = ("spacing", "smoothing_length", "particle_mass")
_SOLVER_KEYS = ("method", "time_step", "cfl", "on_instability", "wall_restitution",
                "surface_threshold", "pair_precision", "density", "density_diffusion", "shifting")
ON_INSTABILITY = ("stop", "retry")
PAIR_PRECISIONS = ("double", "float")
# wcsph's density (docs/method-wcsph.md, W17 / W2); the seed sums
DENSITIES = ("continuity", "summation")


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
DEFAULT_DENSITY_DIFFUSION = 0.1  # wcsph with continuity: delta (W18)
# wcsph with continuity: the shifting coefficient k (W21), or "auto": AUTO_SHIFTING
# in a flow with no free surface at its start (a confined one), none in others
DEFAULT_SHIFTING = "auto"
AUTO_SHIFTING = 8.0
CONTINUITY_SMOOTHING_FACTOR = 3.0  # wcsph with continuity: support over spacing
_SHAPE_KEYS = {
    "rectangle": ("shape", "min", "max", "velocity"),
    "circle": ("shape", "center", "radius", "velocity"),
    "polygon": ("shape", "points", "velocity"),
}
_POLYLINE_KEYS = ("polyline", "closed", "velocity")


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

    def contains(self, x: np.ndarray, y: np.ndarray, tol: float) -> np.ndarray:
        if self.shape == "rectangle":
            (x0, y0), (x1, y1) = self.points
            return (x >= x0 - tol) & (x <= x1 + tol) & (y >= y0 - tol) & (y <= y1 + tol)
        if self.shape == "circle":
            (cx, cy), r = self.points[0], self.radius
            return (x - cx) ** 2 + (y - cy) ** 2 <= (r + tol) ** 2
        return _inside_polygon(x, y, self.points)


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
    density: str = "continuity"  # wcsph: "continuity" (W17-W29) or "summation" (W2)
    density_diffusion: float = DEFAULT_DENSITY_DIFFUSION  # wcsph with continuity: delta
    shifting: float | str = DEFAULT_SHIFTING  # wcsph with continuity: k (0: none) or "auto"
    periodic: tuple[bool, bool] = (False, False)  # the domain wraps along x / y
    probes: Any = None  # probes.Probes: measurement probes (extension), or None
    source: str | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.method != "wcsph" and self.density != "summation":
            object.__setattr__(self, "density", "summation")  # the seed sums (SPEC.md)

    def _walls_json(self) -> list:
        """The walls as the scene format writes them: a moving surface's segment as
        {"polyline": [a, b], "velocity": [u, v]}."""
        out = []
        for k, (a, b) in enumerate(self.walls):
            v = self.wall_velocities[k] if self.wall_velocities else (0.0, 0.0)
            if any(v):
                out.append({"polyline": [list(a), list(b)], "velocity": list(v)})
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
        return int(sum(r.area() for r in self.regions) / self.spacing**2)

    def to_dict(self) -> dict:
        """The scene as a JSON-ready dict that loads back to an equal Scene."""
        regions = []
        for r in self.regions:
            d: dict[str, Any] = {"shape": r.shape}
            if r.shape == "rectangle":
                d["min"], d["max"] = list(r.points[0]), list(r.points[1])
            elif r.shape == "circle":
                d["center"], d["radius"] = list(r.points[0]), r.radius
            else:
                d["points"] = [list(p) for p in r.points]
            if r.velocity != (0.0, 0.0):
                d["velocity"] = list(r.velocity)
            regions.append(d)
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
        if self.method == "wcsph" and self.density == "continuity" and \
                self.shifting != DEFAULT_SHIFTING:
            out["solver"]["shifting"] = self.shifting
        if self.duration is not None:
            out["duration"] = self.duration
        if self.probes is not None:
            out["probes"] = self.probes.to_dict()
        return out


# --------------------------------------------------------------------------- loading

def load_scene(source: str | os.PathLike | Mapping[str, Any]) -> Scene:
    """Read and validate a scene from a JSON file path or an already-parsed dict.

    Raises SceneError naming every problem by its JSON path (and the file).
    """
    if isinstance(source, Mapping):
        return _Validator(dict(source), None).scene()
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
    if not isinstance(data, dict):
        raise SceneError([f"expected a JSON object at the top level, got {_kind(data)}"], label)
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


def _kind(value: Any) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if isinstance(value, dict):
        return "an object"
    return type(value).__name__


class _Domain(NamedTuple):
    lo: Point | None  # lower corner, m; None after a problem
    hi: Point | None  # upper corner, m
    periodic: tuple[bool, bool]


class _Solver(NamedTuple):
    method: Any  # as given: one of METHODS unless a problem was reported
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


def _did_you_mean(word: str, options: Iterable[str]) -> str:
    near = difflib.get_close_matches(word, list(options), n=1)
    return f' (did you mean "{near[0]}"?)' if near else ""


class _Validator:
    """Walks the raw JSON, collecting one message per problem.

    One method per section of the scene, called in the order the problems are
    reported, then the checks that need several sections. The primitives
    return None (or the section's defaults) after reporting a problem.
    """

    def __init__(self, data: dict, source: str | None):
        self.data = data
        self.source = source
        self.problems: list[str] = []

    def fail(self, path: str, message: str) -> None:
        self.problems.append(f"{path}: {message}")

    def missing(self, path: str, why: str = "") -> None:
        self.fail(path, "required key is missing" + (f" ({why})" if why else ""))

    def raise_problems(self) -> None:
        if self.problems:
            raise SceneError(self.problems, self.source)

    # -- the scene
    def scene(self) -> Scene:
        d = self.data
        self.keys(d, _TOP_KEYS, "")
        name, gravity = self.header(d)
        domain = self.domain(d)
        solver = self.solver(d)
        fluid = self.fluid(d, solver.method)
        walls = self.walls(d.get("walls", []))
        if solver.density is None:  # a sliding wall needs the continuity density
            solver = solver._replace(density=default_density(
                solver.method, fluid.sigma, bool(self.wall_velocities())))
        res = self.resolution(d, continuity=solver.method == "wcsph"
                              and solver.density == "continuity")
        regions = self.regions(d)
        duration = self.number_at(d, "duration", "", low=0)
        probes = None
        if "probes" in d:
            from .probes import read_probes

            n_segments = None if any(p.startswith("walls") for p in self.problems) else len(walls)
            probes = read_probes(self, d["probes"], domain.lo, domain.hi, n_segments)

        self.check_cell_grid(domain, res)
        self.check_periodic_extent(domain, res, solver.method, fluid.sigma)
        self.check_tension_lattice(domain, res, solver.method, fluid.sigma)
        self.check_sliding_walls(solver)
        self.check_regions_inside(domain, regions)
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
                      duration=duration, wall_restitution=solver.restitution,
                      surface_threshold=solver.threshold, cfl=solver.cfl,
                      on_instability=solver.on_instability, speed_of_sound=fluid.c0,
                      artificial_viscosity=fluid.alpha, periodic=domain.periodic,
                      background_pressure=fluid.p_b, pair_precision=solver.pair_precision,
                      density=solver.density, density_diffusion=solver.density_diffusion,
                      shifting=solver.shifting, probes=probes, source=self.source)
        self.check_regions_hold_points(scene.regions, res.dx)
        self.raise_problems()
        return scene

    # -- the sections, in the order their problems are reported
    def header(self, d: dict) -> tuple[str, Point | None]:
        """The format, the name and the gravity: (name, gravity)."""
        if "format" not in d:
            self.missing("format")
        elif d["format"] != FORMAT:
            self.fail("format", f'expected "{FORMAT}", got {json.dumps(d["format"])}')
        if "$schema" in d and not isinstance(d["$schema"], str):
            self.fail("$schema", f"expected a string (the schema's path or URL), got "
                      f"{_kind(d['$schema'])}")
        name = d.get("name", "")
        if not isinstance(name, str):
            self.fail("name", f"expected a string, got {_kind(name)}")
            name = ""
        gravity = self.point(d["gravity"], "gravity") if "gravity" in d else DEFAULT_GRAVITY
        return name, gravity

    def domain(self, d: dict) -> _Domain:
        lo = hi = None
        periodic = (False, False)
        dom = self.section(d, "domain", _DOMAIN_KEYS)
        if dom is not None:
            lo = self.point_at(dom, "min", "domain.", required=True)
            hi = self.point_at(dom, "max", "domain.", required=True)
            if lo and hi and not (lo[0] < hi[0] and lo[1] < hi[1]):
                self.fail("domain", f"min must be below max in x and y, got min {list(lo)}, "
                          f"max {list(hi)}")
                lo = hi = None
            if "periodic" in dom:
                periodic = self.flags(dom["periodic"], "domain.periodic")
        return _Domain(lo, hi, periodic)

    def solver(self, d: dict) -> _Solver:
        solver = self.obj(d.get("solver", {}), "solver") or {}
        self.keys(solver, _SOLVER_KEYS, "solver.")
        method = solver.get("method", "seed")
        if method not in METHODS:
            self.fail("solver.method", f"unknown method {json.dumps(method)}"
                      f"{_did_you_mean(str(method), METHODS)}; available: {', '.join(METHODS)}")
        dt, adaptive = self.time_step(solver)
        cfl = self.number_at(solver, "cfl", "solver.", DEFAULT_CFL, low=0, high=1)
        if "cfl" in solver and cfl is not None and not adaptive and "time_step" in solver:
            self.fail("solver.cfl", 'only applies with "time_step": "auto"')
        restitution = self.number_at(solver, "wall_restitution", "solver.", DEFAULT_RESTITUTION,
                                     low=0, strict=False, high=1)
        on_instability = self.choice(solver, "on_instability", "solver.", ON_INSTABILITY)
        pair_precision = self.choice(solver, "pair_precision", "solver.", PAIR_PRECISIONS)
        if pair_precision == "float" and method == "wcsph":
            self.fail("solver.pair_precision", '"float" applies to the seed method only')
        threshold = self.number_at(solver, "surface_threshold", "solver.", low=0, strict=False)
        density = self.choice(solver, "density", "solver.", DENSITIES)
        if method != "wcsph":
            density = "summation"  # the seed's (SPEC.md)
        elif "density" not in solver and not ({"density_diffusion", "shifting"} & set(solver)):
            density = None  # default_density's, once the fluid is known
        diffusion = self.number_at(solver, "density_diffusion", "solver.",
                                   DEFAULT_DENSITY_DIFFUSION, low=0, strict=False)
        shifting = solver.get("shifting", DEFAULT_SHIFTING)
        if not (isinstance(shifting, str) and shifting == "auto"):
            if isinstance(shifting, str):
                self.fail("solver.shifting", f'expected a number or "auto", got {json.dumps(shifting)}')
                shifting = None
            else:
                shifting = self.number(shifting, "solver.shifting", low=0, strict=False)
        for key in ("density", "density_diffusion", "shifting"):
            if key in solver and method != "wcsph":
                self.fail(f"solver.{key}", "applies to the wcsph method only")
        for key in ("density_diffusion", "shifting"):
            if key in solver and density != "continuity":
                self.fail(f"solver.{key}", 'applies with "density": "continuity" only')
        return _Solver(method, dt, adaptive, cfl, restitution, on_instability, pair_precision,
                       threshold, density, diffusion, shifting)

    def time_step(self, solver: dict) -> tuple[float | None, bool]:
        """solver.time_step, seconds or "auto": (dt, adaptive)."""
        if "time_step" not in solver:
            self.missing("solver.time_step", 'a time step in seconds, e.g. 0.0002, or "auto"')
            return None, False
        raw = solver["time_step"]
        if raw == "auto":
            return None, True
        if isinstance(raw, str):
            self.fail("solver.time_step", f'expected a number of seconds or "auto", got '
                      f"{json.dumps(raw)}")
            return None, False
        return self.number(raw, "solver.time_step", low=0), False

    def fluid(self, d: dict, method: Any) -> _Fluid:
        fl = self.section(d, "fluid", _FLUID_KEYS)
        if fl is None:
            return _Fluid(None, None, DEFAULT_VISCOSITY, DEFAULT_SURFACE_TENSION, None, 0.0,
                          DEFAULT_ARTIFICIAL_VISCOSITY)
        p = "fluid."
        return _Fluid(  # arguments run in order: the problems keep the keys' order
            rho0=self.number_at(fl, "rest_density", p, required=True, low=0),
            k=self.number_at(fl, "gas_constant", p, required=method == "seed", low=0,
                             why="the seed method's equation of state p = k (rho - rho0) "
                                 "needs k"),
            eta=self.number_at(fl, "viscosity", p, DEFAULT_VISCOSITY, low=0, strict=False),
            sigma=self.number_at(fl, "surface_tension", p, DEFAULT_SURFACE_TENSION, low=0,
                                 strict=False),
            c0=self.number_at(fl, "speed_of_sound", p, low=0),
            p_b=self.number_at(fl, "background_pressure", p, 0.0, low=0, strict=False),
            alpha=self.number_at(fl, "artificial_viscosity", p, DEFAULT_ARTIFICIAL_VISCOSITY,
                                 low=0, strict=False),
        )

    def resolution(self, d: dict, continuity: bool = False) -> _Resolution:
        """The spacing, the support (by default 2 spacings; 3 for wcsph's continuity
        density, docs/method-wcsph.md) and the particle mass."""
        res = self.section(d, "resolution", _RESOLUTION_KEYS)
        if res is None:
            return _Resolution(None, None, None)
        dx = self.number_at(res, "spacing", "resolution.", required=True, low=0)
        h = None
        if "smoothing_length" in res:
            h = self.number(res["smoothing_length"], "resolution.smoothing_length", low=0)
            if h is not None and dx is not None and h <= dx:
                self.fail("resolution.smoothing_length",
                          f"must be > spacing ({dx:g}), got {h:g}: particles on the "
                          "lattice would not see their neighbours")
                h = None
        elif dx is not None:
            h = (CONTINUITY_SMOOTHING_FACTOR if continuity else DEFAULT_SMOOTHING_FACTOR) * dx
        mass = self.number_at(res, "particle_mass", "resolution.", low=0)
        return _Resolution(dx, h, mass)

    def regions(self, d: dict) -> list[Region]:
        if "fluid_regions" not in d:
            self.missing("fluid_regions")
            return []
        raw = d["fluid_regions"]
        if not isinstance(raw, list):
            self.fail("fluid_regions", f"expected a list, got {_kind(raw)}")
            return []
        regions = [self.region(item, f"fluid_regions[{i}]") for i, item in enumerate(raw)]
        return [r for r in regions if r is not None]

    def region(self, item: Any, path: str) -> Region | None:
        """One fluid region; None if it has any problem."""
        if (item := self.obj(item, path)) is None:
            return None
        shape = item.get("shape")
        if not isinstance(shape, str) or shape not in _SHAPE_KEYS:
            self.fail(f"{path}.shape", f"expected one of rectangle, circle, polygon, got "
                      f"{json.dumps(shape)}{_did_you_mean(str(shape), _SHAPE_KEYS)}")
            return None
        n_before = len(self.problems)
        self.keys(item, _SHAPE_KEYS[shape], f"{path}.")
        velocity = self.point_at(item, "velocity", f"{path}.", (0.0, 0.0))
        read = {"rectangle": self.rectangle, "circle": self.circle,
                "polygon": self.polygon_region}[shape]
        region = read(item, path, velocity or (0.0, 0.0))
        return region if len(self.problems) == n_before else None

    def rectangle(self, item: dict, path: str, velocity: Point) -> Region | None:
        a = self.point_at(item, "min", f"{path}.", required=True)
        b = self.point_at(item, "max", f"{path}.", required=True)
        if not (a and b):
            return None
        if not (a[0] < b[0] and a[1] < b[1]):
            self.fail(path, f"min must be below max in x and y, got min {list(a)}, "
                      f"max {list(b)}")
            return None
        return Region("rectangle", (a, b), velocity=velocity)

    def circle(self, item: dict, path: str, velocity: Point) -> Region | None:
        c = self.point_at(item, "center", f"{path}.", required=True)
        r = self.number_at(item, "radius", f"{path}.", required=True, low=0)
        return Region("circle", (c,), radius=r, velocity=velocity) if c and r else None

    def polygon_region(self, item: dict, path: str, velocity: Point) -> Region | None:
        if "points" not in item:
            self.missing(f"{path}.points")
            return None
        pts = self.polygon(item["points"], f"{path}.points")
        return Region("polygon", tuple(pts), velocity=velocity) if pts else None

    def polygon(self, raw: Any, path: str) -> list[Point] | None:
        if not isinstance(raw, list) or len(raw) < 3:
            self.fail(path, f"expected a list of at least 3 points [x, y], got {_kind(raw)}")
            return None
        pts = [self.point(p, f"{path}[{i}]") for i, p in enumerate(raw)]
        if any(p is None for p in pts):
            return None
        crossing = _self_intersection(pts)
        if crossing:
            i, j = crossing
            self.fail(path, f"polygon is not simple: edge {i} crosses edge {j}")
            return None
        if abs(_polygon_signed_area(pts)) <= 0:
            self.fail(path, "polygon has zero area")
            return None
        return pts

    def walls(self, raw: Any) -> list[tuple[Point, Point]]:
        self._velocities: list[Point] = []  # one per segment
        self._moving_wall = ""  # the path of the first wall whose surface moves
        if not isinstance(raw, list):
            self.fail("walls", f"expected a list, got {_kind(raw)}")
            return []
        out: list[tuple[Point, Point]] = []
        for i, item in enumerate(raw):
            path = f"walls[{i}]"
            if isinstance(item, dict):
                segs = self.polyline(item, path)
                v = self.surface_velocity(item, path, segs)
                out += segs
                self._velocities += [v] * len(segs)
            elif isinstance(item, list) and len(item) == 2:
                segs = self.segment(item, path)
                out += segs
                self._velocities += [(0.0, 0.0)] * len(segs)
            else:
                self.fail(path, "expected a segment [[x1, y1], [x2, y2]] or "
                          f'{{"polyline": [[x, y], ...]}}, got {_kind(item)}')
        return out

    def polyline(self, item: dict, path: str) -> list[tuple[Point, Point]]:
        """The segments of {"polyline": [[x, y], ...], "closed": false}."""
        self.keys(item, _POLYLINE_KEYS, f"{path}.")
        raw = item.get("polyline")
        if not isinstance(raw, list) or len(raw) < 2:
            self.fail(f"{path}.polyline", "expected a list of at least 2 points [x, y], "
                      f"got {_kind(raw)}")
            return []
        closed = item.get("closed", False)
        if not isinstance(closed, bool):
            self.fail(f"{path}.closed", f"expected true or false, got {_kind(closed)}")
            return []
        pts = [self.point(p, f"{path}.polyline[{j}]") for j, p in enumerate(raw)]
        if any(p is None for p in pts):
            return []
        if closed:
            pts = pts + [pts[0]]
        out = []
        for j in range(len(pts) - 1):
            if pts[j] == pts[j + 1]:
                where = f"{path}.polyline[{j + 1}]" if j + 1 < len(raw) else f"{path}.closed"
                self.fail(where, "repeats the previous point (zero-length segment)")
            else:
                out.append((pts[j], pts[j + 1]))
        return out

    def surface_velocity(self, item: dict, path: str, segs: list) -> Point:
        """A polyline's "velocity" [u, v]: its surface slides along it (a lid)."""
        if "velocity" not in item:
            return (0.0, 0.0)
        v = self.point(item["velocity"], f"{path}.velocity")
        if v is None or not any(v):
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
        """A sliding wall's velocity enters wcsph's continuity density only."""
        if getattr(self, "_moving_wall", "") and not (solver.method == "wcsph"
                                                      and solver.density == "continuity"):
            self.fail(self._moving_wall, 'a wall\'s velocity needs "method": "wcsph" with '
                      '"density": "continuity" (docs/method-wcsph.md, W25)')

    def segment(self, item: list, path: str) -> list[tuple[Point, Point]]:
        """[[x1, y1], [x2, y2]] as a list of one segment (none after a problem)."""
        a = self.point(item[0], f"{path}[0]")
        b = self.point(item[1], f"{path}[1]")
        if not (a and b):
            return []
        if a == b:
            self.fail(path, "segment has zero length")
            return []
        return [(a, b)]

    # -- checks across sections
    def check_cell_grid(self, domain: _Domain, res: _Resolution) -> None:
        """The cells of size h over the domain stay within the cell grid's bound."""
        lo, hi, h = domain.lo, domain.hi, res.h
        if not (lo and hi and h):
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

    def check_particle_budget(self, regions: list[Region], dx: float) -> None:
        n = int(sum(r.area() for r in regions) / dx**2)
        need = n * BYTES_PER_PARTICLE
        avail = _available_memory()
        if n > MAX_PARTICLES or (avail is not None and need > 0.8 * avail):
            have = f"{avail / 2**30:.1f} GiB available" if avail else "the 32-bit index limit"
            self.fail("fluid_regions", f"would create about {n:,} particles "
                      f"(~{need / 2**30:.1f} GiB), more than memory allows ({have}); "
                      "increase resolution.spacing")

    def check_regions_hold_points(self, regions: Sequence[Region], dx: float) -> None:
        for i, r in enumerate(regions):
            pos, _ = _fill_regions((r,), dx)
            if len(pos) == 0:
                self.fail(f"fluid_regions[{i}]", f"holds no lattice point at spacing {dx:g} m "
                          "(the region is smaller than the spacing)")

    # -- primitives: a value at a JSON path, checked; None after a problem
    def keys(self, obj: dict, allowed: Sequence[str], prefix: str) -> None:
        for key in obj:
            if key not in allowed:
                near = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
                hint = f' (did you mean "{near[0]}"?)' if near else (
                    f" (expected one of: {', '.join(allowed)})")
                self.fail(f"{prefix}{key}", f"unknown key{hint}")

    def section(self, d: dict, key: str, allowed: Sequence[str]) -> dict | None:
        """The required object d[key], its keys checked; None after a problem."""
        if key not in d:
            self.missing(key)
            return None
        if (obj := self.obj(d[key], key)) is None:
            return None
        self.keys(obj, allowed, f"{key}.")
        return obj

    def obj(self, value: Any, path: str) -> dict | None:
        if not isinstance(value, dict):
            self.fail(path, f"expected an object, got {_kind(value)}")
            return None
        return value

    def number(self, value: Any, path: str, *, low: float | None = None,
               strict: bool = True, high: float | None = None) -> float | None:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            self.fail(path, f"expected a number, got {_kind(value)}")
            return None
        x = float(value)
        if not math.isfinite(x):
            self.fail(path, f"must be finite, got {value!r}")
            return None
        if low is not None and (x <= low if strict else x < low):
            self.fail(path, f"must be {'>' if strict else '>='} {low:g}, got {value!r}")
            return None
        if high is not None and x > high:
            self.fail(path, f"must be <= {high:g}, got {value!r}")
            return None
        return x

    def number_at(self, obj: dict, key: str, prefix: str, default: float | None = None, *,
                  required: bool = False, why: str = "", low: float | None = None,
                  strict: bool = True, high: float | None = None) -> float | None:
        """obj[key] as a number within the limits; if absent, the default (or, when
        required, a problem)."""
        if key not in obj:
            if required:
                self.missing(f"{prefix}{key}", why)
            return default
        return self.number(obj[key], f"{prefix}{key}", low=low, strict=strict, high=high)

    def point(self, value: Any, path: str) -> Point | None:
        if (not isinstance(value, list) or len(value) != 2
                or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in value)):
            shown = json.dumps(value) if _jsonable(value) else repr(value)
            self.fail(path, f"expected [x, y], got {shown}")
            return None
        if not all(math.isfinite(c) for c in value):
            self.fail(path, f"must be finite, got {value!r}")
            return None
        return (float(value[0]), float(value[1]))

    def point_at(self, obj: dict, key: str, prefix: str, default: Point | None = None, *,
                 required: bool = False) -> Point | None:
        """obj[key] as [x, y]; if absent, the default (or, when required, a problem)."""
        if key not in obj:
            if required:
                self.missing(f"{prefix}{key}")
            return default
        return self.point(obj[key], f"{prefix}{key}")

    def flags(self, value: Any, path: str) -> tuple[bool, bool]:
        if not (isinstance(value, list) and len(value) == 2
                and all(isinstance(c, bool) for c in value)):
            shown = json.dumps(value) if _jsonable(value) else repr(value)
            self.fail(path, f"expected [x, y] of true/false, got {shown}")
            return (False, False)
        return (value[0], value[1])

    def choice(self, obj: dict, key: str, prefix: str, options: Sequence[str]) -> Any:
        """obj[key], by default the first option; a problem unless one of the options."""
        value = obj.get(key, options[0])
        if value not in options:
            expected = " or ".join(f'"{o}"' for o in options)
            self.fail(f"{prefix}{key}", f"expected {expected}, got {json.dumps(value)}")
        return value


def _jsonable(value: Any) -> bool:
    try:
        json.dumps(value)
        return True
    except (TypeError, ValueError):
        return False


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


def _segments_cross(p1: Point, p2: Point, q1: Point, q2: Point) -> bool:
    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return (v > 0) - (v < 0)

    def on_segment(a, b, c):
        return (min(a[0], b[0]) <= c[0] <= max(a[0], b[0])
                and min(a[1], b[1]) <= c[1] <= max(a[1], b[1]))

    o1, o2 = orient(p1, p2, q1), orient(p1, p2, q2)
    o3, o4 = orient(q1, q2, p1), orient(q1, q2, p2)
    if o1 != o2 and o3 != o4:
        return True
    return ((o1 == 0 and on_segment(p1, p2, q1)) or (o2 == 0 and on_segment(p1, p2, q2))
            or (o3 == 0 and on_segment(q1, q2, p1)) or (o4 == 0 and on_segment(q1, q2, p2)))


def _self_intersection(pts: Sequence[Point]) -> tuple[int, int] | None:
    edges = list(_edges(pts))
    n = len(edges)
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                continue  # neighbouring edges share a vertex
            if _segments_cross(*edges[i], *edges[j]):
                return i, j
    return None


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
