"""The validation cases: a scene generator, the samples to take while it runs, and
the error against the case's reference (reference.py), for every method.

Each case is run at several resolutions ``n`` (cells across the case's length
scale). ``Case.run`` returns a :class:`Result` with the error, the wall time of
the stepping alone, and the curves the report plots.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from ..dam_break import GEOMETRY
from ..scene import load_scene
from ..simulation import InstabilityError, Simulation
from . import reference as ref

G = 9.81
METHODS = ("seed", "wcsph")
# What the suite runs: the methods, and the seed with its pair forces in float
# (solver.pair_precision), where they run (no surface tension, no periodic axis).
VARIANTS = METHODS + ("seed-float",)
# What runs on request only (--method): dfsph, in progress (docs/method-dfsph.md),
# on the cases it takes (not moving walls, sliding lids, inlets or outlets).
OPTIONAL = ("dfsph",)
CHOICES = VARIANTS + OPTIONAL


def scene_method(variant: str) -> str:
    """The scene's solver.method of a variant."""
    return "seed" if variant == "seed-float" else variant


@dataclass
class Result:
    """One run of a case at one resolution with one method."""

    case: str
    method: str
    n: int  # cells across the case's length scale
    spacing: float  # m
    particles: int = 0
    steps: int = 0
    wall: float = 0.0  # s spent stepping (samples excluded)
    error: float = math.nan  # the case's primary error
    metrics: dict = field(default_factory=dict)  # further errors, by name
    curves: dict = field(default_factory=dict)  # for the profile plots
    failure: str = ""  # the guard's message when the run blew up
    peer: str = ""  # another code's run ("pysph"; `method` is then its label): "" for ours
    note: str = ""  # a peer's set-up and how it differs from ours
    cpu_share: float = math.nan  # a peer's CPU time / (threads x wall): < 1, cores taken

    @property
    def ok(self) -> bool:
        return not self.failure and math.isfinite(self.error)

    @property
    def particle_steps_per_s(self) -> float:
        return self.particles * self.steps / self.wall if self.wall > 0 else math.nan


def _scene(name: str, *, method: str, dx: float, box, fluid: dict, regions: list,
           walls: list, gravity=(0.0, -G), periodic=(False, False), duration: float,
           cfl: float = 0.4, **extensions) -> dict:
    return {
        "format": "sphfluid-scene/1",
        "name": name,
        "gravity": list(gravity),
        "domain": {"min": list(box[0]), "max": list(box[1]),
                   **({"periodic": list(periodic)} if any(periodic) else {})},
        "fluid": fluid,
        "resolution": {"spacing": dx},  # the method's default support
        "fluid_regions": regions,
        "walls": walls,
        "solver": {"method": method, "time_step": "auto", "cfl": cfl},
        "duration": duration,
        **extensions,
    }


def _fluid(method: str, *, rho0: float, c0: float, **extra) -> dict:
    """The fluid block with the sound speed c0 for either method: the seed's is
    sqrt(k), so k = c0^2; wcsph takes c0 itself."""
    sound = {"gas_constant": c0**2} if method == "seed" else {"speed_of_sound": c0}
    return {"rest_density": rho0, **sound, **extra}


def _rect(x0, y0, x1, y1) -> dict:
    return {"shape": "rectangle", "min": [x0, y0], "max": [x1, y1]}


class Case:
    """A validation case. Subclasses give the scene, the sample times, what to
    record at each, and the error of the records."""

    name = ""
    title = ""
    error_name = ""  # what Result.error measures
    length = 1.0  # m: n cells across this length give the spacing
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15, 20), "full": (10, 20, 40)}

    def spacing(self, n: int) -> float:
        return self.length / n

    def scene(self, n: int, method: str) -> dict:
        raise NotImplementedError

    def sample_times(self) -> np.ndarray:
        raise NotImplementedError

    def start(self, sim: Simulation) -> None:
        """Set an initial state the scene format cannot express (default: none)."""

    def sample(self, sim: Simulation) -> dict:
        raise NotImplementedError

    def score(self, samples: list[dict], times: np.ndarray, result: Result) -> None:
        """Fill result.error, result.metrics and result.curves from the samples."""
        raise NotImplementedError

    def applies(self, method: str) -> bool:
        """Whether the variant runs differently from its method here: the float
        pair forces run where the cell clusters do (no surface tension, no
        periodic axis, an AVX-512 build); elsewhere the seed runs in double."""
        if method != "seed-float":
            return True
        d = self.scene(self.resolutions["quick"][0], "seed")
        d["solver"]["pair_precision"] = "float"
        return Simulation(load_scene(d), threads=1)._solver.float_pairs

    def run(self, n: int, method: str, *, threads: int | None = None,
            progress=None) -> Result:
        d = self.scene(n, scene_method(method))
        if method == "seed-float":
            d["solver"]["pair_precision"] = "float"
        scene = load_scene(d)
        sim = Simulation(scene, threads=threads)
        self.start(sim)
        result = Result(self.name, method, n, scene.spacing, particles=sim.n_particles)
        times = self.sample_times()
        samples = []
        try:
            for k, t in enumerate(times):
                begin = time.perf_counter()
                sim.advance_to(float(t))
                result.wall += time.perf_counter() - begin
                if sim.removed_particles:  # every case keeps its fluid in the domain
                    result.failure = (f"{sim.removed_particles} of {result.particles} particles "
                                      f"left the domain by t = {sim.time:.4g} s")
                    break
                samples.append(self.sample(sim))
                if progress:
                    progress(k + 1, len(times), sim)
        except InstabilityError as e:
            result.failure = str(e)
        result.steps = sim.step_count
        if not result.failure:
            self.score(samples, times[:len(samples)], result)
        return result


# --- 1. hydrostatic tank -------------------------------------------------------------


class Hydrostatic(Case):
    """Still water, H = 1 m deep in a 1 m wide tank, filled on the lattice and
    left to settle for t sqrt(g/H) = 15.7 (5 s). Error: the RMS over the particles of p - rho0 g (H - y),
    each averaged over the last second, divided by rho0 g H."""

    name = "hydrostatic"
    title = "Hydrostatic tank"
    error_name = "RMS pressure error / (rho0 g H)"
    depth = 1.0
    duration = 5.0
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15, 20), "full": (10, 20, 40, 80)}

    def scene(self, n, method):
        dx, H = self.spacing(n), self.depth
        if method == "seed":  # the bundled hydrostatic scene's fluid
            fluid = {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 100.0}
        else:
            fluid = {"rest_density": 1000.0}
        return _scene("validation: hydrostatic tank", method=method, dx=dx,
                      box=((-0.1, -0.1), (1.1, 1.6)), fluid=fluid,
                      regions=[_rect(0.0, 0.0, 1.0, H)],
                      walls=[{"polyline": [[0.0, 1.5], [0.0, 0.0], [1.0, 0.0], [1.0, 1.5]]}],
                      duration=self.duration)

    def sample_times(self):
        return np.r_[np.linspace(0.25, self.duration - 1, 16),
                     np.linspace(self.duration - 0.95, self.duration, 20)]

    def sample(self, sim):
        v = sim.velocities
        order = np.argsort(sim.ids)
        return {"t": sim.time, "vmax": float(np.sqrt((v**2).sum(1)).max()),
                "kinetic": 0.5 * sim.particle_mass * float((v**2).sum()),
                "y": sim.positions[order, 1].copy(), "p": sim.pressures[order].copy(),
                "rho": sim.densities[order].copy()}

    def score(self, samples, times, result):
        rho0, H = 1000.0, self.depth
        scale = rho0 * G * H
        # The last second (about ten acoustic periods 4H/c0) averaged per particle:
        # the settled profile without the ringing that is left.
        late = [s for s in samples if s["t"] > self.duration - 1.0 + 1e-9]
        if any(len(s["p"]) != len(late[0]["p"]) for s in late):
            result.failure = "particles were lost from the tank"
            return
        y = np.mean([s["y"] for s in late], axis=0)
        p = np.mean([s["p"] for s in late], axis=0)
        p_ref = ref.hydrostatic_pressure(y, depth=H, rho0=rho0)
        last = samples[-1]
        result.error = float(np.sqrt(np.mean((p - p_ref) ** 2)) / scale)
        snapshot = ref.hydrostatic_pressure(last["y"], depth=H, rho0=rho0)
        result.metrics = {
            "RMS error of one snapshot": float(np.sqrt(np.mean((last["p"] - snapshot) ** 2))
                                               / scale),
            "max |rho/rho0 - 1|": float(np.abs(last["rho"] / rho0 - 1).max()),
            "max |v| / sqrt(gH)": last["vmax"] / math.sqrt(G * H),
            # the residual kinetic energy; M = rho0 H x 1 m, the column's mass
            "kinetic energy / (M g H)": last["kinetic"] / (rho0 * H * G * H),
            "bottom p / (rho0 g H)": float(p[y < 2 * result.spacing].mean() / scale),
        }
        result.curves = {"y": y, "p": p,
                         "t": np.array([s["t"] for s in samples]),
                         "vmax": np.array([s["vmax"] for s in samples])}


# --- 2. dam break -------------------------------------------------------------------


def surge_front(pos: np.ndarray, dx: float) -> float:
    """The largest x reached by fluid that holds together: the rightmost particle
    with at least two others within 2 dx (spray is skipped), plus dx/2."""
    order = np.argsort(pos[:, 0])[::-1]
    for i in order[:200]:
        close = ((pos - pos[i]) ** 2).sum(1) < (2 * dx) ** 2
        if close.sum() >= 3:
            return float(pos[i, 0] + dx / 2)
    return float(pos[order[0], 0] + dx / 2)


class DamBreak(Case):
    """A 1 x 2 m column (a = 1 m) released in a 4 m tank, against Martin & Moyce
    (1952), n^2 = 2. Error: mean |dZ| of the surge front over the Table 2 points
    before the front reaches the far wall (Z < 4), with no time shift. Also
    the density error: at each sample the |rho/rho0 - 1| that 99.9 % of the
    particles stay within, the largest over the collapse (until the front is
    within the kernel's support of the far wall) and, apart, the largest at
    the impact that ends the run (a weakly compressible fluid's water hammer,
    rho c0 U, compresses the tip of the surge by up to U / c0)."""

    name = "dam_break"
    title = "Dam break (Martin & Moyce 1952)"
    error_name = "mean |dZ| of the front, no time shift"
    a = GEOMETRY.a
    tank = GEOMETRY.tank
    duration = 0.72  # T = t sqrt(2g/a) = 3.19: the front is at the far wall
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15, 20), "full": (10, 20, 40, 80)}

    def scene(self, n, method):
        if method == "seed":  # the bundled dam-break scene's fluid
            fluid = {"gas_constant": 250.0, "viscosity": 30.0}
        else:
            fluid = {}
        return GEOMETRY.scene(self.spacing(n), name="validation: dam break", fluid=fluid,
                              solver={"method": method, "time_step": "auto", "cfl": 0.4},
                              duration=self.duration)

    def sample_times(self):
        return np.linspace(0.0, self.duration, 73)[1:]

    def sample(self, sim):
        pos, dx = sim.positions, sim.scene.spacing
        back = pos[pos[:, 0] < 2 * dx]
        height = float(back[:, 1].max() + dx / 2) if len(back) else 0.0
        error = np.abs(sim.densities / sim.scene.rest_density - 1)
        front = surge_front(pos, dx)
        return {"front": front, "height": height, "density": float(np.quantile(error, 0.999)),
                "collapse": front < self.tank - sim.scene.smoothing_length}

    def score(self, samples, times, result):
        a = self.a
        t = np.r_[0.0, times]
        z = np.r_[a, [s["front"] for s in samples]]
        eta = np.r_[2 * a, [s["height"] for s in samples]]
        result.error = ref.mean_front_error(t, z, a, max_z=self.tank / a)
        shift, shifted = ref.best_shift_front_error(t, z, a, max_z=self.tank / a)
        result.metrics = {
            "mean |dZ|, best shift": shifted,
            "best shift in T": shift,
            "mean |dH| (Table 6)": ref.mean_height_error(t, eta, a),
            "99.9 % of |rho/rho0 - 1| within, collapse":
                max((s["density"] for s in samples if s["collapse"]), default=math.nan),
            "99.9 % of |rho/rho0 - 1| within, impact":
                max((s["density"] for s in samples if not s["collapse"]), default=math.nan),
        }
        result.curves = {"T": t * ref.front_time_scale(a), "Z": z / a,
                         "tau": t * ref.height_time_scale(a), "H": eta / (2 * a)}


class WallPressure(Case):
    """The dam break of Buchner (2002) and Zhou et al. (1999): a column H = 0.6 m
    high and 2H wide released in a tank 5.366H long and 3H high, against the
    pressure measured on the far wall at sensor P1 (0.16 m = 0.267H above the
    floor). The scene measures it as a user would, with a "walls" probe on a
    9 mm piece of the far wall (the sensor's size in TrixiParticles.jl's set-up):
    the pressure force on it divided by its length. Error: mean |p - p_exp| /
    (rho g H) over the measured points 2 <= t sqrt(g/H) <= 7, no time shift; the
    delta-SPH of Marrone et al. (2011) scores 0.12-0.14 on it."""

    name = "wall_pressure"
    title = "Dam break: pressure on the far wall (Buchner 2002)"
    error_name = "mean |dp| / (rho g H) at P1, 2 <= t* <= 7"
    length = 0.6  # H: n cells across the column's height
    tank, tank_height = 5.366 * 0.6, 1.8
    sensors = {"P1": 0.16, "P1_0.2H": 0.12}  # m above the floor
    sensor_size = 0.009  # m
    t_end = 7.5  # t sqrt(g/H)
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 20),
                                                         "full": (20, 40, 80, 160)}

    @property
    def duration(self) -> float:
        return self.t_end * math.sqrt(self.length / G)

    def scene(self, n, method):
        H, L, top = self.length, self.tank, self.tank_height
        if method == "seed":  # the bundled dam-break scene's fluid
            fluid = {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0}
        else:
            fluid = {"rest_density": 1000.0}
        # the far wall in pieces, each sensor one of them (segments 2, 4: see probes)
        far = [[L, 0.0]]
        for y in sorted(self.sensors.values()):
            far += [[L, y - self.sensor_size / 2], [L, y + self.sensor_size / 2]]
        polyline = [[0.0, 0.0], *far, [L, top], [0.0, top]]
        d = _scene("validation: dam break against a wall", method=method, dx=self.spacing(n),
                   box=((-0.05, -0.05), (L + 0.05, top + 0.05)), fluid=fluid,
                   regions=[_rect(0.0, 0.0, 2 * H, H)],
                   walls=[{"polyline": polyline, "closed": True}], duration=self.duration)
        by_height = sorted(self.sensors, key=self.sensors.get)
        d["probes"] = {"walls": [{"name": name, "segments": [2 + 2 * by_height.index(name)]}
                                 for name in self.sensors]}
        return d

    def sample_times(self):
        return np.linspace(0.0, self.duration, int(round(self.t_end / 0.02)) + 1)[1:]

    def sample(self, sim):
        from ..probes import sample

        values = sample(sim)
        return {name: values[f"{name}.fx"] / self.sensor_size for name in self.sensors}

    def score(self, samples, times, result):
        H = self.length
        t_star = times * math.sqrt(G / H)
        scale = 1000.0 * G * H
        p = {name: np.array([s[name] for s in samples]) / scale for name in self.sensors}
        result.error = ref.mean_pressure_error(t_star, p["P1"])
        p1 = p["P1"]
        plateau = (t_star >= 3.5) & (t_star <= 5.0)
        first = t_star <= 4.0
        k = int(np.argmax(np.where(first, p1, -np.inf)))
        rising = np.flatnonzero(p1 > 0.1)
        result.metrics = {
            "at 0.2H (Adami 2012's probe)": ref.mean_pressure_error(t_star, p["P1_0.2H"]),
            "onset t* (p* > 0.1; measured 2.49)": float(t_star[rising[0]]) if len(rising)
            else math.nan,
            "first peak p* (measured 0.69 at t* 2.75)": float(p1[k]),
            "plateau p*, 3.5 <= t* <= 5 (measured 0.54)": float(p1[plateau].mean()),
        }
        result.curves = {"t_star": t_star, "p_star": p1, "p_star_0.2H": p["P1_0.2H"]}


# --- 3. Poiseuille flow ---------------------------------------------------------------


class Poiseuille(Case):
    """Start-up of body-force-driven flow between plates 1 mm apart (Morris, Fox &
    Zhu 1997: nu = 1e-6 m^2/s, F = 2e-4 m/s^2, rho = 1000), periodic in x. Error:
    the largest |v_x - v_exact| / v_max over the rows of particles at the five
    sample times."""

    name = "poiseuille"
    title = "Poiseuille flow (Morris, Fox & Zhu 1997)"
    error_name = "max |dv| / v_max over rows and times"
    length = 1e-3  # plate gap L
    nu, force, rho0 = 1e-6, 2e-4, 1000.0
    c0 = 5e-3  # m/s: 200 x v_max, Mach 0.005 (Morris et al. use the same order)
    times = (0.0225, 0.045, 0.1125, 0.225, 1.0)
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15, 20), "full": (10, 20, 40)}

    def scene(self, n, method):
        L, dx = self.length, self.spacing(n)
        width = 10 * dx  # the periodic x extent
        fluid = _fluid(method, rho0=self.rho0, c0=self.c0, viscosity=self.nu * self.rho0)
        reach = 4 * dx  # plates run past the seam so no particle sees their ends
        return _scene("validation: Poiseuille flow", method=method, dx=dx,
                      box=((0.0, -0.5 * L), (width, 1.5 * L)), fluid=fluid,
                      regions=[_rect(0.0, 0.0, width, L)],
                      walls=[[[-reach, 0.0], [width + reach, 0.0]],
                             [[-reach, L], [width + reach, L]]],
                      gravity=(self.force, 0.0), periodic=(True, False),
                      duration=self.times[-1])

    def sample_times(self):
        return np.array(self.times)

    def sample(self, sim):
        return {"y": sim.positions[:, 1].copy(), "vx": sim.velocities[:, 0].copy()}

    def score(self, samples, times, result):
        L, dx = self.length, result.spacing
        v0 = ref.poiseuille_centre_max(L, self.nu, self.force)
        worst = 0.0
        profiles = []
        for s, t in zip(samples, times):
            rows = np.clip((s["y"] / dx).astype(int), 0, round(L / dx) - 1)
            count = np.bincount(rows, minlength=round(L / dx))
            y = np.bincount(rows, s["y"], len(count)) / np.maximum(count, 1)
            vx = np.bincount(rows, s["vx"], len(count)) / np.maximum(count, 1)
            exact = ref.poiseuille_velocity(y, float(t), gap=L, nu=self.nu, force=self.force)
            worst = max(worst, float(np.abs(vx - exact)[count > 0].max() / v0))
            profiles.append((float(t), y, vx))
        result.error = worst
        centre = [np.interp(L / 2, y, vx) / v0 for _, y, vx in profiles]
        result.metrics = {"centreline v / v_max at t = 1 s": float(centre[-1])}
        result.curves = {"profiles": profiles, "v0": v0}


# --- 4. Taylor-Green vortex -------------------------------------------------------------


class TaylorGreen(Case):
    """The decaying vortex array in a periodic 1 x 1 m box, U = 1 m/s, Re = 100
    (nu = 0.01 m^2/s), c0 = 10 U; particles start on a lattice with the exact
    velocity. Error: the largest |v - v_exact| over the particles at t = 1 s,
    divided by the exact maximum speed then."""

    name = "taylor_green"
    title = "Taylor-Green vortex, Re = 100"
    error_name = "L-inf velocity error at t = 1 s / |v|max"
    length, speed, nu, rho0 = 1.0, 1.0, 0.01, 1000.0
    c0 = 10.0
    duration = 1.0
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (20, 30, 40), "full": (25, 50, 100)}

    def scene(self, n, method):
        L = self.length
        fluid = _fluid(method, rho0=self.rho0, c0=self.c0, viscosity=self.nu * self.rho0)
        return _scene("validation: Taylor-Green vortex", method=method, dx=self.spacing(n),
                      box=((0.0, 0.0), (L, L)), fluid=fluid, regions=[_rect(0.0, 0.0, L, L)],
                      walls=[], gravity=(0.0, 0.0), periodic=(True, True),
                      duration=self.duration)

    def start(self, sim):
        x = sim.positions.copy()
        u, v = ref.taylor_green_velocity(x[:, 0], x[:, 1], 0.0, length=self.length,
                                         speed=self.speed, nu=self.nu)
        sim.set_state(x, np.c_[u, v], sim.ids.copy())

    def sample_times(self):
        return np.linspace(0.05, self.duration, 20)

    def sample(self, sim):
        x, v = sim.positions, sim.velocities
        u, w = ref.taylor_green_velocity(x[:, 0], x[:, 1], sim.time, length=self.length,
                                         speed=self.speed, nu=self.nu)
        return {"t": sim.time, "vmax": float(np.sqrt((v**2).sum(1)).max()),
                "linf": float(np.sqrt((v[:, 0] - u) ** 2 + (v[:, 1] - w) ** 2).max())}

    def score(self, samples, times, result):
        t = np.array([s["t"] for s in samples])
        vmax = np.array([s["vmax"] for s in samples])
        exact = self.speed * ref.taylor_green_decay(t, length=self.length, nu=self.nu)
        result.error = samples[-1]["linf"] / exact[-1]
        rate = float(np.polyfit(t, np.log(vmax), 1)[0])
        exact_rate = -8 * math.pi**2 * self.nu / self.length**2
        result.metrics = {
            "|v|max error at t = 1 s": float(abs(vmax[-1] / exact[-1] - 1)),
            "decay rate error": abs(rate / exact_rate - 1),
        }
        result.curves = {"t": t, "vmax": vmax, "exact": exact}


# --- 5. droplet ---------------------------------------------------------------------------


class Droplet(Case):
    """A 0.2 m square of liquid (sigma = 10 N/m, rho = 1000, nu = 0.02 m^2/s, no
    gravity) rounds up into a circle of R = 0.2/sqrt(pi); after 3 s, the pressure
    inside (particles within R/2 of the centre) against Laplace's sigma/R. Error:
    |dp - sigma/R| / (sigma/R)."""

    name = "droplet"
    title = "Droplet: Laplace pressure"
    error_name = "|dp / (sigma/R) - 1|"
    length = 0.2  # side of the square
    sigma, rho0, nu = 10.0, 1000.0, 0.02
    c0 = 10.0
    duration = 3.0
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15, 20), "full": (10, 20, 40)}

    def scene(self, n, method):
        s = self.length
        fluid = _fluid(method, rho0=self.rho0, c0=self.c0, viscosity=self.nu * self.rho0,
                       surface_tension=self.sigma)
        return _scene("validation: droplet", method=method, dx=self.spacing(n),
                      box=((-0.5, -0.5), (0.5, 0.5)), fluid=fluid,
                      regions=[_rect(-s / 2, -s / 2, s / 2, s / 2)], walls=[],
                      gravity=(0.0, 0.0), duration=self.duration)

    def sample_times(self):
        return np.linspace(0.1, self.duration, 30)

    def sample(self, sim):
        x = sim.positions
        r = np.sqrt(((x - x.mean(0)) ** 2).sum(1))
        radius = self.length / math.sqrt(math.pi)
        v = sim.velocities
        return {"t": sim.time, "p_in": float(sim.pressures[r < radius / 2].mean()),
                "vmax": float(np.sqrt((v**2).sum(1)).max()), "r": r, "p": sim.pressures.copy()}

    def score(self, samples, times, result):
        radius = self.length / math.sqrt(math.pi)
        laplace = ref.laplace_pressure_jump(self.sigma, radius)
        last = samples[-1]
        result.error = abs(last["p_in"] / laplace - 1)
        result.metrics = {"dp / (sigma/R)": last["p_in"] / laplace,
                          "max |v| at the end, m/s": last["vmax"]}
        result.curves = {"t": np.array([s["t"] for s in samples]),
                         "p_in": np.array([s["p_in"] for s in samples]), "laplace": laplace,
                         "r": last["r"], "p": last["p"]}


class Oscillation(Case):
    """A circular drop (R = 0.1 m, sigma = 10 N/m, rho = 1000, nu = 1e-4 m^2/s, no
    gravity) started with the n = 2 mode's velocity field u = A (x, -y)/R: its
    quadrupole moment <x^2 - y^2> oscillates with omega^2 = 6 sigma/(rho R^3)
    (2D, in vacuum). Error: |T_sim / T - 1| of the period from the zero crossings."""

    name = "oscillation"
    title = "Droplet: n = 2 oscillation"
    error_name = "|period / (2 pi / omega) - 1|"
    radius = 0.1
    length = 0.2  # the diameter: n cells across it
    sigma, rho0, nu = 10.0, 1000.0, 1e-4
    c0 = 10.0
    amplitude = 0.1  # of the radius' deformation
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15, 20), "full": (10, 20, 40)}

    @property
    def omega(self) -> float:
        return ref.droplet_frequency(self.sigma, self.rho0, self.radius, mode=2)

    @property
    def duration(self) -> float:
        return 2.5 * 2 * math.pi / self.omega

    def scene(self, n, method):
        fluid = _fluid(method, rho0=self.rho0, c0=self.c0, viscosity=self.nu * self.rho0,
                       surface_tension=self.sigma)
        return _scene("validation: oscillating droplet", method=method, dx=self.spacing(n),
                      box=((-0.5, -0.5), (0.5, 0.5)), fluid=fluid,
                      regions=[{"shape": "circle", "center": [0.0, 0.0],
                                "radius": self.radius}],
                      walls=[], gravity=(0.0, 0.0), duration=self.duration)

    def start(self, sim):
        x = sim.positions.copy()
        speed = self.amplitude * self.radius * self.omega  # deformation rate at the rim
        v = speed / self.radius * np.c_[x[:, 0], -x[:, 1]]
        sim.set_state(x, v, sim.ids.copy())

    def sample_times(self):
        return np.linspace(0.0, self.duration, 301)[1:]

    def sample(self, sim):
        x = sim.positions - sim.positions.mean(0)
        return {"t": sim.time, "q": float(np.mean(x[:, 0] ** 2 - x[:, 1] ** 2))}

    def score(self, samples, times, result):
        t = np.array([s["t"] for s in samples])
        q = np.array([s["q"] for s in samples])
        q = q - q.mean()
        down = np.nonzero((q[:-1] > 0) & (q[1:] <= 0))[0]
        up = np.nonzero((q[:-1] < 0) & (q[1:] >= 0))[0]
        crossings = np.sort(np.r_[down, up])
        exact = 2 * math.pi / self.omega
        result.curves = {"t": t, "q": q, "period": exact}
        if len(crossings) < 3:
            result.metrics = {"zero crossings": len(crossings)}
            return  # no oscillation: the error stays NaN and the run counts as failed
        # Interpolated crossing times; successive ones are half a period apart.
        tc = t[crossings] - q[crossings] * (t[crossings + 1] - t[crossings]) / (
            q[crossings + 1] - q[crossings])
        period = 2 * float(np.mean(np.diff(tc)))
        result.error = abs(period / exact - 1)
        result.metrics = {"period, s": period, "analytic period, s": exact}


def _mls_linear(x: np.ndarray, f: np.ndarray, points: np.ndarray, h: float) -> np.ndarray:
    """f (n, k) at each point: the value of the linear least-squares fit to the
    particles within h, weighted by the Wendland C2 kernel (first-order exact)."""
    out = np.empty((len(points), f.shape[1]))
    for k, p in enumerate(points):
        r = x - p
        d = np.sqrt((r**2).sum(1))
        near = d < h
        q = d[near] / h
        w = (1.0 - q) ** 4 * (1.0 + 4.0 * q)
        a = np.c_[np.ones(near.sum()), r[near]]
        coef = np.linalg.lstsq(a * np.sqrt(w)[:, None], f[near] * np.sqrt(w)[:, None],
                               rcond=None)[0]
        out[k] = coef[0]
    return out


# --- 7. lid-driven cavity --------------------------------------------------------------


class Cavity(Case):
    """A 1 x 1 m box whose lid slides at U = 1 m/s, Re = 100 (nu = 0.01 m^2/s),
    c0 = 10 U, from rest on the lattice, to t = 30 s (how much the centreline
    velocities still move over the last 10 s is reported). A wall whose
    surface slides needs wcsph's continuity density (its default;
    docs/method-wcsph.md, W25) or dfsph (the seed does not run it). Error: the largest |u - u_Ghia| on the
    vertical centreline and |v - v_Ghia| on the horizontal one (Ghia, Ghia &
    Shin 1982; their interior points), the SPH velocities interpolated there by
    a linear least-squares fit over the particles within h (Wendland weights;
    a Shepard average would smooth the lid's boundary layer) and averaged over
    the last 5 s, divided by U."""

    name = "cavity"
    title = "Lid-driven cavity, Re = 100 (Ghia, Ghia & Shin 1982)"
    error_name = "max |u - u_Ghia| / U on the centrelines"
    length, speed, nu, rho0 = 1.0, 1.0, 0.01, 1000.0
    c0 = 10.0
    duration = 30.0
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (20, 30), "full": (25, 50, 100)}

    def applies(self, method):
        return method in ("wcsph", "dfsph")

    def scene(self, n, method):
        L = self.length
        fluid = _fluid(method, rho0=self.rho0, c0=self.c0, viscosity=self.nu * self.rho0)
        return _scene("validation: lid-driven cavity", method=method, dx=self.spacing(n),
                      box=((-0.1, -0.1), (1.1, 1.1)), fluid=fluid,
                      regions=[_rect(0.0, 0.0, L, L)],
                      walls=[{"polyline": [[0.0, L], [0.0, 0.0], [L, 0.0], [L, L]]},
                             {"polyline": [[0.0, L], [L, L]], "velocity": [self.speed, 0.0]}],
                      gravity=(0.0, 0.0), duration=self.duration)

    def sample_times(self):
        return np.linspace(self.duration - 10.0, self.duration, 21)

    def sample(self, sim):
        h = sim.scene.smoothing_length
        x, v = sim.positions, sim.velocities
        ys, _ = ref.ghia_cavity("u_vertical")
        xs, _ = ref.ghia_cavity("v_horizontal")
        u = _mls_linear(x, v, np.c_[np.full_like(ys, 0.5), ys], h)[:, 0]
        w = _mls_linear(x, v, np.c_[xs, np.full_like(xs, 0.5)], h)[:, 1]
        return {"t": sim.time, "u": u, "v": w}

    def score(self, samples, times, result):
        ys, u_ref = ref.ghia_cavity("u_vertical")
        xs, v_ref = ref.ghia_cavity("v_horizontal")
        late = [s for s in samples if s["t"] >= self.duration - 5.0 - 1e-9]
        u = np.mean([s["u"] for s in late], axis=0) / self.speed
        v = np.mean([s["v"] for s in late], axis=0) / self.speed
        inner_u = (ys > 0) & (ys < 1)  # the lid and the floor are boundary values
        inner_v = (xs > 0) & (xs < 1)
        du = np.abs(u - u_ref)[inner_u]
        dv = np.abs(v - v_ref)[inner_v]
        result.error = float(max(du.max(), dv.max()))
        first = samples[0]
        drift = max(np.abs(samples[-1]["u"] - first["u"]).max(),
                    np.abs(samples[-1]["v"] - first["v"]).max()) / self.speed
        result.metrics = {"max |du| / U": float(du.max()), "max |dv| / U": float(dv.max()),
                          "centreline change over the last 10 s / U": float(drift)}
        result.curves = {"y": ys, "u": u, "u_ref": u_ref, "x": xs, "v": v, "v_ref": v_ref}


# --- 9. filling a basin -----------------------------------------------------------


class Basin(Case):
    """A tap fills a basin: an emitter 0.1 m wide pours water straight down at
    1 m/s from 0.2 m above the rim of a basin 0.6 m wide and 0.8 m deep, for 1.5 s;
    at 3 s the water should stand at the level the inflow predicts, the emitted
    particles' area (count x spacing^2) over the basin's width. Water that splashes
    over the rim lands beside the basin, in a closed room. Error: |level / predicted level - 1| at
    t = 3 s, the level the 98th percentile of the heights of the particles in the
    basin's middle (0.1 to 0.25 m from its centre) plus half a spacing."""

    name = "basin"
    title = "Filling a basin"
    error_name = "|level / predicted - 1| at t = 3 s"
    length = 0.6  # the basin's width
    rim, width, speed, stop, duration = 0.8, 0.1, 1.0, 1.5, 3.0
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (15, 20, 30),
                                                         "full": (15, 30, 60)}

    def scene(self, n, method):
        if method == "seed":  # the bundled scenes' viscous fluid
            fluid = {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0}
        else:
            fluid = {"rest_density": 1000.0, "viscosity": 1e-3}
        d = _scene("validation: filling a basin", method=method, dx=self.spacing(n),
                   box=((-0.05, -0.05), (1.05, 2.05)), fluid=fluid, regions=[],
                   walls=[{"polyline": [[0.2, 0.0], [0.0, 0.0], [0.0, 2.0], [1.0, 2.0],
                                        [1.0, 0.0], [0.8, 0.0]]},  # a closed room
                          {"polyline": [[0.2, self.rim], [0.2, 0.0], [0.8, 0.0],
                                        [0.8, self.rim]]}],
                   duration=self.duration)
        d["emitters"] = [{"name": "tap", "at": [0.5, self.rim + 0.2], "width": self.width,
                          "speed": self.speed, "stop": self.stop}]
        return d

    def sample_times(self):
        return np.linspace(0.25, self.duration, 12)

    def sample(self, sim):
        x = sim.positions
        inside = (x[:, 0] > 0.2) & (x[:, 0] < 0.8) & (x[:, 1] < self.rim)
        off_jet = inside & (np.abs(x[:, 0] - 0.5) > 0.1) & (np.abs(x[:, 0] - 0.5) < 0.25)
        dx = sim.scene.spacing
        level = float(np.percentile(x[off_jet, 1], 98)) + 0.5 * dx if off_jet.any() else 0.0
        return {"t": sim.time, "level": level, "emitted": sim.balance["in"],
                "inside": int(inside.sum())}

    def score(self, samples, times, result):
        dx = result.spacing
        last = samples[-1]
        predicted = last["emitted"] * dx * dx / self.length
        result.particles = last["emitted"]
        result.error = abs(last["level"] / predicted - 1)
        t = np.array([s["t"] for s in samples])
        level = np.array([s["level"] for s in samples])
        result.metrics = {"level, m": last["level"], "predicted level, m": predicted,
                          "splashed out of the basin": last["emitted"] - last["inside"]}
        result.curves = {"t": t, "level": level,
                         "predicted": np.array([s["emitted"] for s in samples]) * dx * dx
                         / self.length}


# --- 10. piston wave maker ------------------------------------------------------


class WaveMaker(Case):
    """A piston wave maker: a vertical wall at the end of a tank 3.5 m long with
    water h = 0.3 m deep moves as x(t) = (S/2) r(t) sin(2 pi t / T), S = 0.04 m,
    T = 1 s, r ramping from 0 to 1 over the first period (a table of 40 points
    a period); a damping zone (the scene's default strength) over the last
    1.5 m (about a wavelength, 1.37 m) absorbs the waves. Linear theory gives
    waves of height H = S 2 (cosh 2kh - 1) / (sinh 2kh + 2kh) (Biesel & Suquet
    1951; kh = 1.37 here, H/S = 1.30). Error: |H / H_theory - 1|, H twice the
    amplitude of the sinusoid of period T fitted to the surface height 1 m from
    the piston (3.3 depths: past the piston's local disturbance) over 3 to 12 s.
    The reflection coefficient comes from a second gauge 0.3 m further (the
    incident and reflected waves separated by linear theory, after Goda &
    Suzuki 1976)."""

    name = "wave_maker"
    title = "Piston wave maker"
    error_name = "|H / H_theory - 1|"
    length = 0.3  # the depth
    stroke, period, tank, beach, probe, duration = 0.04, 1.0, 3.5, 1.5, 1.0, 12.0
    gauge2 = 1.3  # the reflection's second gauge, m from the piston
    window = (3.0, 12.0)
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 15), "full": (10, 20, 30)}

    def motion(self) -> list:
        t = np.arange(0.0, self.duration + 0.5, self.period / 40)
        x = 0.5 * self.stroke * np.minimum(t / self.period, 1.0) * np.sin(
            2 * np.pi * t / self.period)
        return [[float(a), float(b), 0.0] for a, b in zip(t, x)]

    def scene(self, n, method):
        h, L = self.length, self.tank
        if method == "seed":  # the bundled scenes' viscous fluid
            fluid = {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0}
        else:
            fluid = {"rest_density": 1000.0, "viscosity": 1e-3}
        return _scene("validation: piston wave maker", method=method, dx=self.spacing(n),
                      box=((-0.15, -0.05), (L + 0.05, 2 * h + 0.05)), fluid=fluid,
                      regions=[_rect(0.0, 0.0, L, h)],
                      walls=[{"polyline": [[-0.1, 0.0], [L, 0.0], [L, 2 * h]]},
                             {"polyline": [[0.0, 0.0], [0.0, 2 * h]],
                              "motion": {"translation": self.motion()}}],
                      duration=self.duration,
                      damping_zones=[{"name": "beach", "from": [L - self.beach, 0.0],
                                      "to": [L, 0.0]}])

    def sample_times(self):
        return np.arange(self.period / 20, self.duration + 1e-9, self.period / 20)

    def sample(self, sim):
        from ..probes import Probes, SurfaceProbe, sample

        heights = sample(sim, Probes(surface=(SurfaceProbe("s", self.probe),
                                              SurfaceProbe("r", self.gauge2))))
        return {"t": sim.time, "eta": heights["s.height"] - self.length,
                "eta2": heights["r.height"] - self.length}

    def score(self, samples, times, result):
        t = np.array([s["t"] for s in samples])
        eta = np.array([s["eta"] for s in samples])
        w = (t >= self.window[0] - 1e-9) & (t <= self.window[1] + 1e-9) & np.isfinite(eta)
        omega = 2 * np.pi / self.period
        basis = np.c_[np.cos(omega * t[w]), np.sin(omega * t[w]), np.ones(w.sum())]
        (a, b, c), *_ = np.linalg.lstsq(basis, eta[w], rcond=None)
        height = 2 * math.hypot(a, b)
        kh = ref.wave_number(self.period, self.length) * self.length
        theory = self.stroke * ref.piston_height_ratio(kh)
        result.error = abs(height / theory - 1)
        fit = basis @ np.array([a, b, c])
        # The reflection: each gauge's complex amplitude A (eta = Re(A e^(-i w t)))
        # is a_I e^(ikx) + a_R e^(-ikx) for the incident and reflected waves.
        eta2 = np.array([s["eta2"] for s in samples])
        w2 = w & np.isfinite(eta2)
        amp = []
        for e in (eta, eta2):
            (p, q, _), *_ = np.linalg.lstsq(basis[w2[w]], e[w2], rcond=None)
            amp.append(p + 1j * q)
        k = kh / self.length
        x = np.array([self.probe, self.gauge2])
        a_in, a_re = np.linalg.solve(np.c_[np.exp(1j * k * x), np.exp(-1j * k * x)], amp)
        result.metrics = {"H, m": height, "H_theory, m": theory, "kh": kh,
                          "reflection coefficient": float(abs(a_re) / abs(a_in)),
                          "mean level change, m": float(c),
                          "RMS misfit of the sinusoid / H": float(
                              np.sqrt(np.mean((eta[w] - fit) ** 2)) / height)}
        result.curves = {"t": t, "eta": eta, "theory": theory}


# --- 11. channel with an inlet and an outlet -----------------------------------------


class Channel(Case):
    """A plane channel H = 0.1 m high and 0.6 m long between no-slip walls, fed
    by a uniform inlet at U = 0.1 m/s at its left and emptied by an outlet at its
    right (no periodic axis), the fluid at rest on the lattice at the start, no
    gravity, nu = 1e-3 m^2/s (Re = U H / nu = 10; the entrance length is about
    0.9 H). Downstream the flow takes Poiseuille's profile with the inflow's
    flux, u = 1.5 U (1 - (2y/H - 1)^2). Error: the largest |u_row - u| / (1.5 U)
    over the rows of the profile averaged over 0.3-0.4 m from the inlet and over
    t = 6-8 s (the slowest viscous mode then decays below 0.3 %)."""

    name = "channel"
    title = "Channel with an inlet and an outlet"
    error_name = "max |du| / u_max over rows, x 0.3-0.4 m, t 6-8 s"
    length = 0.1  # H: n cells across the channel
    channel, speed, nu, rho0 = 0.6, 0.1, 1e-3, 1000.0
    # The viscous pressure drop, 12 rho nu U L / H^2 = 72 Pa, would compress the
    # fluid 7 % at the default speed of sound (10 U); at 3 m/s (20 x the top
    # speed) 0.8 %.
    c0 = 3.0
    window, slab = (6.0, 8.0), (0.3, 0.4)
    resolutions: ClassVar[dict[str, tuple[int, ...]]] = {"quick": (10, 20), "full": (10, 20, 40)}

    def scene(self, n, method):
        # the buffers' depth at the method's default support (Scene.buffer_depth)
        return self._scene(n, method, load_scene(self._scene(n, method, 0.0)).buffer_depth())

    def _scene(self, n, method, depth):
        H, L, dx = self.length, self.channel, self.spacing(n)
        fluid = _fluid(method, rho0=self.rho0, c0=self.c0, viscosity=self.nu * self.rho0)
        d = _scene("validation: channel with an inlet and an outlet", method=method, dx=dx,
                   box=((0.0, 0.0), (L + 2 * depth, H)), fluid=fluid,
                   regions=[_rect(depth, 0.0, depth + L, H)],
                   walls=[{"polyline": [[0.0, 0.0], [L + 2 * depth, 0.0]]},
                          {"polyline": [[0.0, H], [L + 2 * depth, H]]}],
                   gravity=(0.0, 0.0), duration=self.window[1])
        if depth:
            d["inlets"] = [{"at": [depth, H / 2], "direction": [1, 0], "width": H,
                            "speed": self.speed}]
            d["outlets"] = [{"at": [depth + L, H / 2], "direction": [1, 0], "width": H}]
        return d

    def sample_times(self):
        return np.linspace(0.5, self.window[1], 16)

    def sample(self, sim):
        depth = sim.scene.buffer_depth()
        x, v = sim.positions, sim.velocities
        inside = (x[:, 0] >= depth + self.slab[0]) & (x[:, 0] < depth + self.slab[1])
        b = sim.balance
        return {"t": sim.time, "y": x[inside, 1].copy(), "u": v[inside, 0].copy(),
                "in": b["in"], "out": b["out"], "lost": b["lost"], "now": b["now"]}

    def score(self, samples, times, result):
        H, dx, U = self.length, result.spacing, self.speed
        rows = round(H / dx)
        late = [s for s in samples if s["t"] >= self.window[0] - 1e-9]
        y = np.concatenate([s["y"] for s in late])
        u = np.concatenate([s["u"] for s in late])
        row = np.clip((y / dx).astype(int), 0, rows - 1)
        count = np.bincount(row, minlength=rows)
        ym = np.bincount(row, y, rows) / np.maximum(count, 1)
        um = np.bincount(row, u, rows) / np.maximum(count, 1)
        exact = ref.channel_velocity(ym, H, U)
        result.error = float(np.abs(um - exact)[count > 0].max() / (1.5 * U))
        first, last = late[0], late[-1]
        rate = (last["out"] - first["out"]) / (last["t"] - first["t"])
        inflow = U * H / dx**2  # particles a second
        result.metrics = {"mean u / U over the slab": float(u.mean() / U),
                          "outflow / inflow, t 6-8 s": float(rate / inflow),
                          "lost (left the domain)": last["lost"]}
        result.curves = {"y": ym, "u": um, "u_ref": exact}


CASES: dict[str, Case] = {c.name: c for c in (Hydrostatic(), DamBreak(), WallPressure(),
                                               Poiseuille(),
                                               TaylorGreen(), Droplet(), Oscillation(),
                                               Cavity(), Basin(), WaveMaker(), Channel())}
