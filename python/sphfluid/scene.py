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
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

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
# wcsph's surface energy (cpp/surface_energy.hpp): its smallest h over dx, and
# the most nodes (16 bytes each) its lattice over the domain may need.
MIN_TENSION_SMOOTHING = 1.5
MAX_TENSION_NODES = 50_000_000
BYTES_PER_PARTICLE = 512  # state, sort scratch, neighbour lists, set-up temporaries
MAX_PARTICLES = 2**31 - 2  # particle indices are 32-bit in the core

_TOP_KEYS = ("format", "name", "gravity", "domain", "fluid", "resolution", "fluid_regions",
             "walls", "solver", "duration")
_DOMAIN_KEYS = ("min", "max", "periodic")
_FLUID_KEYS = ("rest_density", "gas_constant", "viscosity", "surface_tension",
               "speed_of_sound", "artificial_viscosity", "background_pressure")
_RESOLUTION_KEYS = ("spacing", "smoothing_length", "particle_mass")
_SOLVER_KEYS = ("method", "time_step", "cfl", "on_instability", "wall_restitution",
                "surface_threshold", "pair_precision")
ON_INSTABILITY = ("stop", "retry")
PAIR_PRECISIONS = ("double", "float")
_SHAPE_KEYS = {
    "rectangle": ("shape", "min", "max", "velocity"),
    "circle": ("shape", "center", "radius", "velocity"),
    "polygon": ("shape", "points", "velocity"),
}
_POLYLINE_KEYS = ("polyline", "closed")


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
    periodic: tuple[bool, bool] = (False, False)  # the domain wraps along x / y
    source: str | None = field(default=None, compare=False)

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
            "walls": [[list(a), list(b)] for a, b in self.walls],
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
        if self.duration is not None:
            out["duration"] = self.duration
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


class _Validator:
    """Walks the raw JSON, collecting one message per problem."""

    def __init__(self, data: dict, source: str | None):
        self.data = data
        self.source = source
        self.problems: list[str] = []

    def fail(self, path: str, message: str) -> None:
        self.problems.append(f"{path}: {message}")

    # -- primitive checks; each returns None after reporting a problem
    def keys(self, obj: dict, allowed: Sequence[str], prefix: str) -> None:
        for key in obj:
            if key not in allowed:
                near = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
                hint = f' (did you mean "{near[0]}"?)' if near else (
                    f" (expected one of: {', '.join(allowed)})")
                self.fail(f"{prefix}{key}", f"unknown key{hint}")

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

    def flags(self, value: Any, path: str) -> tuple[bool, bool]:
        if not (isinstance(value, list) and len(value) == 2
                and all(isinstance(c, bool) for c in value)):
            shown = json.dumps(value) if _jsonable(value) else repr(value)
            self.fail(path, f"expected [x, y] of true/false, got {shown}")
            return (False, False)
        return (value[0], value[1])

    def required(self, obj: dict, key: str, prefix: str, why: str = "") -> Any:
        if key not in obj:
            self.fail(f"{prefix}{key}", "required key is missing" + (f" ({why})" if why else ""))
            return None
        return obj[key]

    def req_point(self, obj: dict, key: str, prefix: str) -> Point | None:
        if key not in obj:
            self.fail(f"{prefix}{key}", "required key is missing")
            return None
        return self.point(obj[key], f"{prefix}{key}")

    # -- the scene
    def scene(self) -> Scene:
        d = self.data
        self.keys(d, _TOP_KEYS, "")
        fmt = self.required(d, "format", "")
        if fmt is not None and fmt != FORMAT:
            self.fail("format", f'expected "{FORMAT}", got {json.dumps(fmt)}')
        name = d.get("name", "")
        if not isinstance(name, str):
            self.fail("name", f"expected a string, got {_kind(name)}")
            name = ""
        gravity = self.point(d["gravity"], "gravity") if "gravity" in d else DEFAULT_GRAVITY

        lo = hi = None
        periodic = (False, False)
        dom = self.required(d, "domain", "")
        if dom is not None and (dom := self.obj(dom, "domain")) is not None:
            self.keys(dom, _DOMAIN_KEYS, "domain.")
            lo = self.req_point(dom, "min", "domain.")
            hi = self.req_point(dom, "max", "domain.")
            if lo and hi and not (lo[0] < hi[0] and lo[1] < hi[1]):
                self.fail("domain", f"min must be below max in x and y, got min {list(lo)}, "
                          f"max {list(hi)}")
                lo = hi = None
            if "periodic" in dom:
                periodic = self.flags(dom["periodic"], "domain.periodic")

        solver = d.get("solver", {})
        solver = self.obj(solver, "solver") or {}
        self.keys(solver, _SOLVER_KEYS, "solver.")
        method = solver.get("method", "seed")
        if method not in METHODS:
            near = difflib.get_close_matches(str(method), METHODS, n=1)
            hint = f' (did you mean "{near[0]}"?)' if near else ""
            self.fail("solver.method", f"unknown method {json.dumps(method)}{hint}; "
                      f"available: {', '.join(METHODS)}")
        dt = None
        adaptive = False
        if "time_step" not in solver:
            self.fail("solver.time_step", 'required key is missing (a time step in seconds, '
                      'e.g. 0.0002, or "auto")')
        elif solver["time_step"] == "auto":
            adaptive = True
        elif isinstance(solver["time_step"], str):
            self.fail("solver.time_step", f'expected a number of seconds or "auto", got '
                      f'{json.dumps(solver["time_step"])}')
        else:
            dt = self.number(solver["time_step"], "solver.time_step", low=0)
        cfl = DEFAULT_CFL
        if "cfl" in solver:
            cfl = self.number(solver["cfl"], "solver.cfl", low=0, high=1)
            if cfl is not None and not adaptive and "time_step" in solver:
                self.fail("solver.cfl", 'only applies with "time_step": "auto"')
        restitution = DEFAULT_RESTITUTION
        if "wall_restitution" in solver:
            restitution = self.number(solver["wall_restitution"], "solver.wall_restitution",
                                      low=0, strict=False, high=1)
        on_instability = solver.get("on_instability", "stop")
        if on_instability not in ON_INSTABILITY:
            self.fail("solver.on_instability", f'expected "stop" or "retry", got '
                      f"{json.dumps(on_instability)}")
        pair_precision = solver.get("pair_precision", "double")
        if pair_precision not in PAIR_PRECISIONS:
            self.fail("solver.pair_precision", f'expected "double" or "float", got '
                      f"{json.dumps(pair_precision)}")
        elif pair_precision == "float" and method == "wcsph":
            self.fail("solver.pair_precision", '"float" applies to the seed method only')
        threshold = None
        if "surface_threshold" in solver:
            threshold = self.number(solver["surface_threshold"], "solver.surface_threshold",
                                    low=0, strict=False)

        rho0 = k = c0 = None
        eta, sigma = DEFAULT_VISCOSITY, DEFAULT_SURFACE_TENSION
        alpha = DEFAULT_ARTIFICIAL_VISCOSITY
        p_b = 0.0
        fl = self.required(d, "fluid", "")
        if fl is not None and (fl := self.obj(fl, "fluid")) is not None:
            self.keys(fl, _FLUID_KEYS, "fluid.")
            if "rest_density" in fl:
                rho0 = self.number(fl["rest_density"], "fluid.rest_density", low=0)
            else:
                self.fail("fluid.rest_density", "required key is missing")
            if "gas_constant" in fl:
                k = self.number(fl["gas_constant"], "fluid.gas_constant", low=0)
            elif method == "seed":
                self.fail("fluid.gas_constant", "required key is missing (the seed method's "
                          "equation of state p = k (rho - rho0) needs k)")
            if "viscosity" in fl:
                eta = self.number(fl["viscosity"], "fluid.viscosity", low=0, strict=False)
            if "surface_tension" in fl:
                sigma = self.number(fl["surface_tension"], "fluid.surface_tension", low=0,
                                    strict=False)
            if "speed_of_sound" in fl:
                c0 = self.number(fl["speed_of_sound"], "fluid.speed_of_sound", low=0)
            if "background_pressure" in fl:
                p_b = self.number(fl["background_pressure"], "fluid.background_pressure",
                                  low=0, strict=False)
            if "artificial_viscosity" in fl:
                alpha = self.number(fl["artificial_viscosity"], "fluid.artificial_viscosity",
                                    low=0, strict=False)

        dx = h = mass = None
        res = self.required(d, "resolution", "")
        if res is not None and (res := self.obj(res, "resolution")) is not None:
            self.keys(res, _RESOLUTION_KEYS, "resolution.")
            if "spacing" in res:
                dx = self.number(res["spacing"], "resolution.spacing", low=0)
            else:
                self.fail("resolution.spacing", "required key is missing")
            if "smoothing_length" in res:
                h = self.number(res["smoothing_length"], "resolution.smoothing_length", low=0)
                if h is not None and dx is not None and h <= dx:
                    self.fail("resolution.smoothing_length",
                              f"must be > spacing ({dx:g}), got {h:g}: particles on the "
                              "lattice would not see their neighbours")
                    h = None
            elif dx is not None:
                h = DEFAULT_SMOOTHING_FACTOR * dx
            if "particle_mass" in res:
                mass = self.number(res["particle_mass"], "resolution.particle_mass", low=0)

        regions = self.regions(d)
        walls = self.walls(d.get("walls", []))
        duration = None
        if "duration" in d:
            duration = self.number(d["duration"], "duration", low=0)

        if lo and hi and h:
            cells = ((hi[0] - lo[0]) / h) * ((hi[1] - lo[1]) / h)
            if cells > MAX_DOMAIN_CELLS:
                self.fail("domain", f"spans {cells:.3g} cells of the smoothing length "
                          f"{h:g} m, more than the {MAX_DOMAIN_CELLS:.0e} the cell grid allows; "
                          "shrink the domain to where the fluid can go")
        if lo and hi and h:
            for axis, axis_name, extent in ((0, "x", "wide"), (1, "y", "high")):
                if periodic[axis] and hi[axis] - lo[axis] < 2 * h:
                    self.fail("domain.periodic", f"a periodic {axis_name} axis needs a domain at "
                              f"least 2 smoothing lengths ({2 * h:g} m) {extent}, got "
                              f"{hi[axis] - lo[axis]:g} m")
                elif (periodic[axis] and method == "wcsph" and sigma and dx
                      and hi[axis] - lo[axis] < 4 * h + dx / 2):
                    # cpp/surface_energy.hpp: the colour field's support is 2 h
                    self.fail("domain.periodic", f"with surface tension, wcsph needs a periodic "
                              f"{axis_name} axis at least 4 smoothing lengths plus half a spacing "
                              f"({4 * h + dx / 2:g} m) {extent}, got {hi[axis] - lo[axis]:g} m")
        if method == "wcsph" and sigma and dx and h:
            # cpp/surface_energy.hpp: the surface energy is summed on nodes dx/2
            # apart over the fluid's bounding box, with a colour kernel of support 2 h.
            if h < MIN_TENSION_SMOOTHING * dx:
                self.fail("resolution.smoothing_length", f"with surface tension, wcsph needs "
                          f"h of at least {MIN_TENSION_SMOOTHING:g} spacings ({h / dx:.3g} "
                          "given): below that the fluid's own lattice ripple outweighs the "
                          "surface (README, \"The wcsph method\"); 2 spacings is the default")
            elif lo and hi:
                nodes = ((hi[0] - lo[0] + 4 * h) / (dx / 2) + 1) * (
                    (hi[1] - lo[1] + 4 * h) / (dx / 2) + 1)
                if nodes > MAX_TENSION_NODES:
                    self.fail("domain", f"with surface tension, wcsph sums the surface energy "
                              f"on nodes half a spacing apart over the fluid's extent: this "
                              f"domain could need {nodes:.3g} of them, more than the "
                              f"{MAX_TENSION_NODES:.0e} allowed ({16 * MAX_TENSION_NODES / 1e9:g} "
                              "GB); shrink the domain to where the fluid can go")
        if lo and hi:
            for i, r in enumerate(regions):
                (x0, y0), (x1, y1) = r.bounds()
                if x0 < lo[0] or y0 < lo[1] or x1 > hi[0] or y1 > hi[1]:
                    self.fail(f"fluid_regions[{i}]", "reaches outside the domain (its "
                              "particles there would be removed at once)")
        if dx and regions and not self.problems:
            self.check_particle_budget(regions, dx)

        if self.problems:
            raise SceneError(self.problems, self.source)
        assert adaptive or dt is not None
        scene = Scene(domain_min=lo, domain_max=hi, rest_density=rho0, gas_constant=k,
                      spacing=dx, smoothing_length=h, time_step=dt, name=name,
                      gravity=gravity, viscosity=eta, surface_tension=sigma,
                      particle_mass=mass, regions=tuple(regions), walls=tuple(walls),
                      method=method, duration=duration, wall_restitution=restitution,
                      surface_threshold=threshold, cfl=cfl, on_instability=on_instability,
                      speed_of_sound=c0, artificial_viscosity=alpha, periodic=periodic,
                      background_pressure=p_b, pair_precision=pair_precision,
                      source=self.source)
        for i, r in enumerate(scene.regions):
            pos, _ = _fill_regions((r,), dx)
            if len(pos) == 0:
                self.fail(f"fluid_regions[{i}]", f"holds no lattice point at spacing {dx:g} m "
                          "(the region is smaller than the spacing)")
        if self.problems:
            raise SceneError(self.problems, self.source)
        return scene

    def check_particle_budget(self, regions: list[Region], dx: float) -> None:
        n = int(sum(r.area() for r in regions) / dx**2)
        need = n * BYTES_PER_PARTICLE
        avail = _available_memory()
        if n > MAX_PARTICLES or (avail is not None and need > 0.8 * avail):
            have = f"{avail / 2**30:.1f} GiB available" if avail else "the 32-bit index limit"
            self.fail("fluid_regions", f"would create about {n:,} particles "
                      f"(~{need / 2**30:.1f} GiB), more than memory allows ({have}); "
                      "increase resolution.spacing")

    def regions(self, d: dict) -> list[Region]:
        raw = self.required(d, "fluid_regions", "")
        if raw is None:
            return []
        if not isinstance(raw, list):
            self.fail("fluid_regions", f"expected a list, got {_kind(raw)}")
            return []
        out = []
        for i, item in enumerate(raw):
            path = f"fluid_regions[{i}]"
            if (item := self.obj(item, path)) is None:
                continue
            shape = item.get("shape")
            if shape not in _SHAPE_KEYS:
                near = difflib.get_close_matches(str(shape), list(_SHAPE_KEYS), n=1)
                hint = f' (did you mean "{near[0]}"?)' if near else ""
                self.fail(f"{path}.shape", f"expected one of rectangle, circle, polygon, got "
                          f"{json.dumps(shape)}{hint}")
                continue
            n_before = len(self.problems)
            self.keys(item, _SHAPE_KEYS[shape], f"{path}.")
            vel = self.point(item["velocity"], f"{path}.velocity") if "velocity" in item else (0.0, 0.0)
            if shape == "rectangle":
                a = self.req_point(item, "min", f"{path}.")
                b = self.req_point(item, "max", f"{path}.")
                if a and b and not (a[0] < b[0] and a[1] < b[1]):
                    self.fail(path, f"min must be below max in x and y, got min {list(a)}, "
                              f"max {list(b)}")
                    continue
                region = Region("rectangle", (a, b), velocity=vel) if a and b else None
            elif shape == "circle":
                c = self.req_point(item, "center", f"{path}.")
                r = None
                if "radius" in item:
                    r = self.number(item["radius"], f"{path}.radius", low=0)
                else:
                    self.fail(f"{path}.radius", "required key is missing")
                region = Region("circle", (c,), radius=r, velocity=vel) if c and r else None
            else:
                pts = self.polygon(item.get("points"), f"{path}.points") if "points" in item else None
                if "points" not in item:
                    self.fail(f"{path}.points", "required key is missing")
                region = Region("polygon", tuple(pts), velocity=vel) if pts else None
            if region is not None and vel is not None and len(self.problems) == n_before:
                out.append(region)
        return out

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
        if not isinstance(raw, list):
            self.fail("walls", f"expected a list, got {_kind(raw)}")
            return []
        out: list[tuple[Point, Point]] = []
        for i, item in enumerate(raw):
            path = f"walls[{i}]"
            if isinstance(item, dict):
                self.keys(item, _POLYLINE_KEYS, f"{path}.")
                pts_raw = item.get("polyline")
                if not isinstance(pts_raw, list) or len(pts_raw) < 2:
                    self.fail(f"{path}.polyline", "expected a list of at least 2 points [x, y], "
                              f"got {_kind(pts_raw)}")
                    continue
                closed = item.get("closed", False)
                if not isinstance(closed, bool):
                    self.fail(f"{path}.closed", f"expected true or false, got {_kind(closed)}")
                    continue
                pts = [self.point(p, f"{path}.polyline[{j}]") for j, p in enumerate(pts_raw)]
                if any(p is None for p in pts):
                    continue
                if closed:
                    pts = pts + [pts[0]]
                for j in range(len(pts) - 1):
                    if pts[j] == pts[j + 1]:
                        where = (f"{path}.polyline[{j + 1}]" if j + 1 < len(pts_raw)
                                 else f"{path}.closed")
                        self.fail(where, "repeats the previous point (zero-length segment)")
                    else:
                        out.append((pts[j], pts[j + 1]))
            elif isinstance(item, list) and len(item) == 2:
                a = self.point(item[0], f"{path}[0]")
                b = self.point(item[1], f"{path}[1]")
                if a and b:
                    if a == b:
                        self.fail(path, "segment has zero length")
                    else:
                        out.append((a, b))
            else:
                self.fail(path, "expected a segment [[x1, y1], [x2, y2]] or "
                          f'{{"polyline": [[x, y], ...]}}, got {_kind(item)}')
        return out


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
