"""PySPH's own examples on our accuracy validation cases, scored with our errors.

Runs one of PySPH's example applications (``pysph.examples.*``), set up for one of
our validation cases (sphfluid.validation.cases), in a subprocess: the example's
Application is built with command-line options, its solver writes its output files
into a temporary directory at the times our case samples, and this process reads
them back (``pysph.solver.utils.load``) and scores them with our case's own
``sample`` and ``score`` methods, so that the error is computed by the same code
as ours. A crash or a hang of PySPH cannot take the caller down.

    python benchmarks/peers/pysph_cases.py --list
    python benchmarks/peers/pysph_cases.py --case taylor_green --scheme edac --n 25 \\
        [--threads 2] [--timeout 3600] [--end-time 30]

prints the result of :func:`run_case` as a JSON line (and its progress on stderr).
``sphfluid validate --peers`` runs every pair of :data:`PAIRS` for the cases it
runs, at :func:`resolutions`, and shows them beside ours, labelled by
:func:`label`; :func:`availability` says first whether PySPH can run here.

The cases, and how each example is set up (``note`` in the result repeats it):

``taylor_green`` (``pysph.examples.taylor_green``; schemes edac, tvf, wcsph)
    ``--nx n --re 100 --perturb 0`` (the lattice start, also its default): our
    box, U, nu and c0 = 10 U; its density is rho0 = 1 (ours 1000, which the
    velocity error does not see). Samples at our times, np.linspace(0.05, 1, 20) s.
``poiseuille`` (``pysph.examples.poiseuille``; scheme tvf)
    The example is non-dimensional: plates at y = 0 and y = 1, nu = 0.01, its
    body force set by ``--re`` (Re = v_max gap / nu). With ``--re 0.025``, our
    Re (Morris et al.: gap 1 mm, nu 1e-6, F 2e-4 m/s^2, v_max 2.5e-5 m/s), the
    start-up flow is ours in units of the gap and the viscous time gap^2/nu, which
    is 100 s for the example and 1 s for us: it is sampled at 100 x our times, and
    scored against the same Morris series with its own gap, nu and force, divided
    by its own v_max. Its spacing is a module constant (1/60); it is set to 1/n
    with the two constants the example derives from it (h = dx, the walls 5 dx
    deep). Its width, its sound speed (10 v_max; ours 200 v_max) and its time step
    are the example's.
``hydrostatic`` (``pysph.examples.hydrostatic_tank``; schemes adami, monaghan_kajtar,
dynamic: its ``--bc-type`` 1, 2, 3)
    The example fixes its geometry in module constants (a 2 m wide tank, water
    0.9 m deep, g = 1, 2 s); they are set to ours (1 m wide, 1 m deep, walls to
    1.5 m, g = 9.81, rho0 = 1000, 5 s, dx = 1/n), and the constants the example
    derives from them are re-derived by its rules (c0 = 10 sqrt(gH), nu =
    sqrt(gH) L_y / 100, h = 1.2 dx, walls 5.5 dx deep, dt = 0.75 min(0.25 h/(c0 +
    sqrt(gH)), 0.125 h^2/nu, 0.25 sqrt(h/g))). Its gravity ramp (over 1 s, i.e.
    t sqrt(g/H) = 1.05) keeps that non-dimensional length: 0.34 s here; the
    Monaghan-Kajtar wall's K (0.02 m^2/s^2, a literal of its equations) is scaled
    with g H too (0.218). Its formulation otherwise: linear EOS, continuity
    density, artificial viscosity 0.24-0.25, the fluid on the lattice at rho0.
``cavity`` (``pysph.examples.cavity``; schemes tvf, edac)
    ``--nx n --re 100``, run to our 30 s (its default is 10 s; ``end_time`` sets
    another, then the last 5 s are still averaged). Our interpolation: the linear
    least-squares fit within our h at that spacing (3 dx, the example's kernel
    support), over the fluid particles.

Every run uses the example's kernel, smoothing length, integrator and time step.
``wall_s`` is the wall-clock time of the example's time stepping alone: the
solver's ``solve`` timed in the subprocess, less the time spent writing output
files; ``cpu_s`` is the CPU time of all its threads over ``solve`` (about
``threads`` x ``wall_s`` when the cores are free: a smaller ratio shows that
another job took them). The set-up (with PySPH's compilation of its kernels on
a new configuration) is reported apart, in ``setup_s``. PySPH runs with OpenMP
(``--openmp``) on ``threads`` threads (``OMP_NUM_THREADS``); it compiles into the
cache ``~/.pysph`` of a HOME that is set to a directory of the system's
temporary directory (:data:`CACHE_DIR`), kept between runs.

The subprocess imports PySPH and numpy only, never sphfluid (an editable install
of sphfluid may rebuild its extension when imported): what it needs of our cases
(their times, Re, the tank) comes in its configuration file, written by
:func:`run_case`, which imports sphfluid.validation on first use. It reports on
stdout, one line each (``@pysph-case KIND {json}``): ``start`` after the set-up
(version, particles, ``setup_s``, ``t_end``), ``progress`` at each output time
(``t``, ``steps``, ``wall_s`` so far) and ``done`` at the end (the totals), so that
a run that times out or crashes still has its particle count and how far it got.
The subprocess runs in a session of its own, which is killed whole (PySPH and the
compiler it may have started) when it times out or the caller is interrupted.
"""
from __future__ import annotations

import argparse
import copy
import importlib
import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from sphfluid.validation.cases import Case

__all__ = [
    "CACHE_DIR",
    "PAIRS",
    "SCHEME_NAMES",
    "Snapshot",
    "availability",
    "label",
    "main",
    "our_case",
    "read_snapshots",
    "resolutions",
    "run_case",
    "schemes",
    "score",
]

CACHE_DIR = Path(tempfile.gettempdir()) / "sphfluid-pysph-home"  # HOME of the runs
FNAME = "pysph_case"  # the output files' prefix
_TAG = "@pysph-case"  # prefix of the subprocess' report lines on stdout
PEER_MODULE = "pysph"  # what availability() imports
REQUIREMENT = "pysph==1.0b2"  # the version these drivers were written against
PROBE_TIMEOUT = 120.0  # s for availability()'s import of PySPH
_QUIET_PFREQ = 10**9  # output every this many steps: never; only at our sample times

# (case, scheme) -> the example's options choosing the scheme
PAIRS: dict[tuple[str, str], tuple[str, ...]] = {
    ("taylor_green", "edac"): ("--scheme", "edac"),
    ("taylor_green", "tvf"): ("--scheme", "tvf"),
    ("taylor_green", "wcsph"): ("--scheme", "wcsph"),
    ("poiseuille", "tvf"): (),  # the example's only scheme
    ("hydrostatic", "adami"): ("--bc-type", "1"),
    ("hydrostatic", "monaghan_kajtar"): ("--bc-type", "2"),
    ("hydrostatic", "dynamic"): ("--bc-type", "3"),
    ("cavity", "tvf"): ("--scheme", "tvf"),
    ("cavity", "edac"): ("--scheme", "edac"),
}

# scheme -> how a table names it (the hydrostatic tank's are its wall models)
SCHEME_NAMES = {
    "edac": "EDAC",
    "tvf": "TVF",
    "wcsph": "WCSPH",
    "adami": "WCSPH, Adami walls",
    "monaghan_kajtar": "WCSPH, Monaghan-Kajtar walls",
    "dynamic": "WCSPH, dynamic walls",
}

_EXAMPLES = {  # case -> (module of pysph.examples, its Application)
    "taylor_green": ("taylor_green", "TaylorGreen"),
    "poiseuille": ("poiseuille", "PoiseuilleFlow"),
    "hydrostatic": ("hydrostatic_tank", "HydrostaticTank"),
    "cavity": ("cavity", "LidDrivenCavity"),
}


def _validation():
    """sphfluid.validation.cases, imported on first use (never in the subprocess)."""
    from sphfluid.validation import cases

    return cases


def schemes(case: str) -> tuple[str, ...]:
    """The schemes PySPH runs a case with (none for a case it has no example of)."""
    return tuple(s for c, s in PAIRS if c == case)


# The finest n PySPH runs a case at in ``--full``: its cost grows as n^3, and above
# these one run takes tens of minutes on 2 threads here (the cavity at 100 across
# about 50 minutes a scheme, four times its 50; the tank at 80 about 8 minutes a
# scheme, three schemes), so that the peers would make the full validation hours.
FULL_MAX_N = {"cavity": 50, "hydrostatic": 40}


def resolutions(case: str, mode: str) -> tuple[int, ...]:
    """The n at which ``sphfluid validate --peers`` runs a case: ours in that mode
    ("quick" or "full"), so that each of our points has PySPH's at the same n
    (every example takes any n >= 2), up to FULL_MAX_N in "full"."""
    if not schemes(case):
        raise ValueError(f"no PySPH peer for case {case!r}")
    ours = tuple(_validation().CASES[case].resolutions[mode])
    top = FULL_MAX_N.get(case) if mode == "full" else None
    return tuple(n for n in ours if top is None or n <= top)


def label(scheme: str, version: str) -> str:
    """How a table names a scheme's rows, e.g. "PySPH 1.0b2 EDAC"."""
    return " ".join(w for w in ("PySPH", version, SCHEME_NAMES[scheme]) if w)


def availability(timeout: float = PROBE_TIMEOUT) -> tuple[str, str]:
    """Whether PySPH can run here: (its version, "") or ("", a one-line reason).

    PySPH and the examples the cases use are imported in a subprocess, so that an
    import that crashes cannot take the caller down.
    """
    if importlib.util.find_spec(PEER_MODULE) is None:
        return "", f"{PEER_MODULE} is not installed (pip install {REQUIREMENT}; docs/peers.md)"
    code = "; ".join([f"import {PEER_MODULE}", f"import {PEER_MODULE}.solver.utils"]
                     + [f"import {PEER_MODULE}.examples.{m}" for m, _ in _EXAMPLES.values()]
                     + [f"print({PEER_MODULE}.__version__)"])
    CACHE_DIR.mkdir(parents=True, exist_ok=True)
    try:
        probe = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                               env=_child_env(1, CACHE_DIR), timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return "", f"importing {PEER_MODULE} took over {timeout:g} s"
    if probe.returncode != 0:
        from sphfluid.bench import exit_reason

        return "", f"importing {PEER_MODULE} failed ({exit_reason(probe.returncode, probe.stderr)})"
    lines = probe.stdout.split()
    return (lines[-1] if lines else "?"), ""


# --------------------------------------------------------------------------------------
# Our cases with the parameters of the PySPH runs
# --------------------------------------------------------------------------------------


def our_case(case: str, params: dict) -> Case:
    """Our validation case with the parameters of a PySPH run of it.

    A copy of ``sphfluid.validation.cases.CASES[case]`` whose attributes are those
    the PySPH example ran with (its units), so that its ``sample_times``,
    ``sample`` and ``score`` apply to the example's output as they are.

    Parameters
    ----------
    case : str
        One of our cases in :data:`PAIRS`.
    params : dict
        The run's parameters, as :func:`run_case`'s subprocess reports them:
        taylor_green: ``length``, ``speed``, ``nu``; poiseuille: ``length`` (the
        gap), ``nu``, ``force``, ``time_scale`` (its time per second of ours);
        hydrostatic: ``depth``, ``rho0``, ``g`` (must be ours: the score uses
        rho0 = 1000 and g = 9.81); cavity: ``length``, ``speed``, ``nu``, and
        ``duration`` (the end time).

    Returns
    -------
    Case
    """
    cases = _validation()
    if case not in _EXAMPLES:
        raise ValueError(f"no PySPH peer for case {case!r}")
    ours = cases.CASES[case]
    c = copy.copy(ours)
    if case == "taylor_green":
        c.length, c.speed, c.nu = params["length"], params["speed"], params["nu"]
    elif case == "poiseuille":
        c.length, c.nu, c.force = params["length"], params["nu"], params["force"]
        c.times = tuple(float(t) * params["time_scale"] for t in ours.times)
    elif case == "hydrostatic":
        if not (math.isclose(params["rho0"], 1000.0) and math.isclose(params["g"], cases.G)):
            raise ValueError(f"the hydrostatic score needs rho0 = 1000 and g = {cases.G} "
                             f"(got {params['rho0']}, {params['g']})")
        c.depth = params["depth"]
    else:
        c.length, c.speed, c.nu = params["length"], params["speed"], params["nu"]
        c.duration = params["duration"]
    return c


def _sample_times(case: Case) -> list[float]:
    """The case's sample times after t = 0 (a short cavity run would ask for t < 0)."""
    return [float(t) for t in case.sample_times() if t > 0.0]


def _reynolds(case: str) -> float:
    """Our Re: U L / nu; for Poiseuille v_max gap / nu, as the example defines it."""
    from sphfluid.validation import reference as ref

    c = _validation().CASES[case]
    if case == "poiseuille":
        return ref.poiseuille_centre_max(c.length, c.nu, c.force) * c.length / c.nu
    return c.speed * c.length / c.nu


def interpolation_h(case: str, n: int) -> float:
    """Our smoothing length at resolution n: the radius of the cavity's velocity fit."""
    from sphfluid.scene import load_scene

    return load_scene(_validation().CASES[case].scene(n, "wcsph")).smoothing_length


# --------------------------------------------------------------------------------------
# Scoring: PySPH's particles through our cases' sample() and score()
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Snapshot:
    """The fluid particles of one PySPH output file (or any other source).

    Attributes
    ----------
    t : float
        Time [s, the run's units].
    x, y, u, v : ndarray
        Positions and velocities.
    p, rho : ndarray
        Pressure and density.
    mass : float
        Particle mass (all equal here).
    ids : ndarray
        A particle's identity across snapshots (its index when the particles
        keep their order).
    """

    t: float
    x: np.ndarray
    y: np.ndarray
    u: np.ndarray
    v: np.ndarray
    p: np.ndarray
    rho: np.ndarray
    mass: float
    ids: np.ndarray


class _State:
    """A snapshot seen as the sphfluid Simulation that our cases' sample() reads."""

    def __init__(self, s: Snapshot, smoothing_length: float):
        self.time = s.t
        self.positions = np.column_stack((s.x, s.y))
        self.velocities = np.column_stack((s.u, s.v))
        self.pressures = np.asarray(s.p, dtype=float)
        self.densities = np.asarray(s.rho, dtype=float)
        self.ids = np.asarray(s.ids)
        self.particle_mass = s.mass
        self.scene = SimpleNamespace(smoothing_length=smoothing_length)


def score(case: str, snapshots: list[Snapshot], n: int, params: dict) -> dict:
    """Our case's error of a run's snapshots, by our case's sample() and score().

    Parameters
    ----------
    case : str
        One of our cases in :data:`PAIRS`.
    snapshots : list of Snapshot
        The fluid at each of ``our_case(case, params).sample_times()`` (after t = 0),
        in order.
    n : int
        Resolution: particles across the case's length scale.
    params : dict
        The run's parameters (see :func:`our_case`).

    Returns
    -------
    dict
        ``error`` (nan if the run cannot be scored), ``metrics`` and ``failure``
        ("" or why it cannot be scored).
    """
    c = our_case(case, params)
    if not all(np.all(np.isfinite(s.u)) and np.all(np.isfinite(s.v)) for s in snapshots):
        return {"error": math.nan, "metrics": {}, "failure": "non-finite velocities"}
    h = interpolation_h(case, n)
    result = _validation().Result(case, "pysph", n, c.spacing(n),
                                  particles=len(snapshots[0].x))
    samples = [c.sample(_State(s, h)) for s in snapshots]
    c.score(samples, np.array([s.t for s in snapshots]), result)
    failure = result.failure or ("" if math.isfinite(result.error) else "non-finite error")
    return {"error": float(result.error), "metrics": dict(result.metrics), "failure": failure}


def read_snapshots(directory: str | Path, times: list[float]) -> list[Snapshot]:
    """The fluid in PySPH's output files of ``directory`` at each of ``times``.

    Raises
    ------
    ValueError
        If a time has no output file.
    """
    from pysph.solver.utils import get_files, iter_output

    found = {}
    for solver_data, fluid in iter_output(get_files(str(directory), FNAME), "fluid"):
        found[float(solver_data["t"])] = fluid
    stamps = np.array(sorted(found))
    out = []
    for t in times:
        k = int(np.argmin(np.abs(stamps - t))) if len(stamps) else -1
        if k < 0 or abs(stamps[k] - t) > 1e-6 * max(1.0, abs(t)):
            raise ValueError(f"no PySPH output at t = {t:g}")
        fluid = found[float(stamps[k])]
        gid = fluid.gid.astype(np.int64)  # unset (all UINT_MAX) in serial runs
        ids = gid if len(np.unique(gid)) == len(gid) else np.arange(len(gid))
        out.append(Snapshot(t=float(stamps[k]), x=fluid.x.copy(), y=fluid.y.copy(),
                            u=fluid.u.copy(), v=fluid.v.copy(), p=fluid.p.copy(),
                            rho=fluid.rho.copy(), mass=float(fluid.m[0]), ids=ids))
    return out


# --------------------------------------------------------------------------------------
# What the subprocess is told: our case's part of the set-up
# --------------------------------------------------------------------------------------


def _example_options(case: str, scheme: str, n: int) -> list[str]:
    """The example's own options for our case."""
    options = list(PAIRS[case, scheme])
    if case in ("taylor_green", "cavity"):
        options += ["--nx", str(n), "--re", f"{_reynolds(case):.12g}"]
    if case == "taylor_green":
        options += ["--perturb", "0"]
    if case == "poiseuille":
        options += ["--re", f"{_reynolds(case):.12g}"]
    return options


def _child_config(case: str, scheme: str, n: int, workdir: str,
                  end_time: float | None) -> dict:
    """The subprocess' configuration: the example's options, our sample times (in our
    units), and for the tank and the cavity what our case sets."""
    cases = _validation()
    ours = copy.copy(cases.CASES[case])
    cfg = {"case": case, "scheme": scheme, "n": n, "workdir": workdir,
           "options": _example_options(case, scheme, n)}
    if case == "poiseuille":
        cfg["viscous_time"] = ours.length**2 / ours.nu  # our time unit: gap^2 / nu
    elif case == "hydrostatic":
        scene = ours.scene(n, "wcsph")
        walls = np.array(scene["walls"][0]["polyline"], dtype=float)
        cfg["tank"] = {"width": float(np.ptp(walls[:, 0])), "wall_top": float(walls[:, 1].max()),
                       "depth": ours.depth, "g": cases.G, "duration": ours.duration}
    elif case == "cavity":
        ours.duration = ours.duration if end_time is None else end_time
        cfg["duration"] = ours.duration
    cfg["times"] = _sample_times(ours)
    return cfg


# --------------------------------------------------------------------------------------
# The subprocess: one example, set up for one case (PySPH and numpy only)
# --------------------------------------------------------------------------------------


def _set_poiseuille_spacing(ex, app, n: int) -> None:
    """The example's resolution is module constants (dx = 1/60): dx = gap/n, with
    h = hdx dx and walls 5 dx deep as the example derives them (and its scheme,
    created with the application, told the new h)."""
    ex.dx = app.Ly / n
    ex.h0 = ex.hdx * ex.dx
    ex.ghost_extent = 5 * ex.dx
    app.scheme.configure(h0=ex.h0)


def _set_hydrostatic_tank(ex, n: int, tank: dict, times: list[float]) -> None:
    """Our tank in the example's module constants, and what it derives from them."""
    gy, depth = ex.gy, ex.H  # the example's
    ramp = ex.tdamp * math.sqrt(abs(gy) / depth)  # its gravity ramp, non-dimensional
    g = tank["g"]
    ex.Lx, ex.Ly, ex.H, ex.gy = tank["width"], tank["wall_top"], tank["depth"], -g
    ex.nx = n
    ex.dx = ex.Lx / n
    ex.Vmax = math.sqrt(g * ex.H)
    ex.c0 = 10 * ex.Vmax
    ex.p0 = ex.c0**2 * ex.rho0
    ex.nu = ex.Vmax * ex.Ly / ex.Re
    ex.ghost_extent = 5.5 * ex.dx
    ex.h0 = ex.hdx * ex.dx
    ex.dt_cfl = 0.25 * ex.h0 / (ex.c0 + ex.Vmax)
    ex.dt_viscous = 0.125 * ex.h0**2 / ex.nu
    ex.dt_force = 0.25 * math.sqrt(ex.h0 / g)
    ex.dt = 0.75 * min(ex.dt_cfl, ex.dt_viscous, ex.dt_force)
    ex.tdamp = ramp * math.sqrt(ex.H / g)
    ex.tf = tank["duration"]
    ex.output_at_times = np.array(times)
    # The Monaghan-Kajtar wall force's K (a squared velocity) is a literal of the
    # example's create_equations, in its units: scaled with g H like everything else.
    force, scale = ex.MonaghanKajtarBoundaryForce, g * ex.H / (abs(gy) * depth)

    def scaled_force(*args, K, **kwargs):
        return force(*args, K=K * scale, **kwargs)

    ex.MonaghanKajtarBoundaryForce = scaled_force


def _run_params(cfg: dict, ex, app) -> dict:
    """The physical parameters the example ran with (what our_case needs, and c0)."""
    case = cfg["case"]
    if case == "taylor_green":
        return {"length": ex.L, "speed": ex.U, "nu": app.nu, "c0": ex.c0, "rho0": ex.rho0}
    if case == "poiseuille":
        scale = (app.Ly**2 / app.nu) / cfg["viscous_time"]
        return {"length": app.Ly, "nu": app.nu, "force": app.fx, "time_scale": scale,
                "c0": app.c0, "v_max": app.Vmax, "rho0": app.rho0}
    if case == "hydrostatic":
        return {"depth": ex.H, "rho0": ex.rho0, "g": abs(ex.gy), "c0": ex.c0,
                "gravity_ramp": ex.tdamp}
    return {"length": ex.L, "speed": ex.Umax, "nu": app.nu, "c0": ex.c0, "rho0": ex.rho0,
            "duration": cfg["duration"]}


def _report(kind: str, **fields) -> None:
    """One report line on stdout (the caller reads them as they come)."""
    print(_TAG, kind, json.dumps(fields), flush=True)


def _child(config_file: str) -> None:
    """Run one example as the configuration file says, reporting as it goes."""
    import pysph

    cfg = json.loads(Path(config_file).read_text(encoding="utf-8"))
    case, n = cfg["case"], cfg["n"]
    module, app_class = _EXAMPLES[case]
    ex = importlib.import_module(f"pysph.examples.{module}")
    app = getattr(ex, app_class)(fname=FNAME, output_dir=cfg["workdir"])
    # the module constants are read when the application is set up, below
    if case == "poiseuille":
        _set_poiseuille_spacing(ex, app, n)
    elif case == "hydrostatic":
        _set_hydrostatic_tank(ex, n, cfg["tank"], cfg["times"])
    begin = time.perf_counter()
    app.setup(cfg["options"] + ["--openmp", "--quiet", "--pfreq", str(_QUIET_PFREQ),
                                "--directory", cfg["workdir"]])
    setup_s = time.perf_counter() - begin
    params = _run_params(cfg, ex, app)
    times = np.array(cfg["times"]) * params.get("time_scale", 1.0)
    solver = app.solver
    solver.set_final_time(float(times[-1]))
    solver.set_output_at_times(times)
    fluid = next(pa for pa in app.particles if pa.name == "fluid")
    particles = fluid.get_number_of_particles(real=True)
    _report("start", version=pysph.__version__, particles=particles, setup_s=setup_s,
            t_end=float(times[-1]))

    clock = {"begin": 0.0, "output": 0.0}  # the stepping's start; time spent writing
    dump = solver.dump_output

    def timed_dump():  # the output at each sample time, not timed as stepping
        start = time.perf_counter()
        dump()
        now = time.perf_counter()
        _report("progress", t=float(solver.t), steps=int(solver.count),
                wall_s=now - clock["begin"] - clock["output"] - (now - start))
        clock["output"] += time.perf_counter() - start

    solver.dump_output = timed_dump
    dt = solver.dt  # the example's time step (the solver shortens some to land on outputs)
    clock["begin"], cpu = time.perf_counter(), time.process_time()
    solver.solve(False)
    total, cpu = time.perf_counter() - clock["begin"], time.process_time() - cpu
    _report("done", version=pysph.__version__, particles=particles,
            all_particles=sum(pa.get_number_of_particles(real=True) for pa in app.particles),
            steps=solver.count, t=solver.t, wall_s=total - clock["output"], cpu_s=cpu,
            output_s=clock["output"], setup_s=setup_s, times=times.tolist(), params=params,
            kernel=type(solver.kernel).__name__, h=float(fluid.h[0]),
            integrator=type(solver.integrator).__name__, dt=dt,
            threads=os.environ.get("OMP_NUM_THREADS", ""))


# --------------------------------------------------------------------------------------
# The caller's side
# --------------------------------------------------------------------------------------


def _note(case: str, scheme: str, n: int, r: dict) -> str:
    """What ran, and how it differs from our set-up."""
    p = r["params"]
    h_dx = r["h"] / our_case(case, p).spacing(n)
    common = (f"PySPH {r['version']} example pysph.examples.{_EXAMPLES[case][0]}, "
              f"{' '.join(PAIRS[case, scheme]) or 'its TVF scheme'}: {r['kernel']} "
              f"h = {h_dx:.3g} dx, {r['integrator']}, dt = {r['dt']:.3g}, "
              f"{r['all_particles'] - r['particles']} wall particles, OpenMP "
              f"{r['threads']} threads.")
    if case == "taylor_green":
        return (f"{common} Options --nx --re 100 --perturb 0: lattice start with the exact "
                f"velocity and pressure, c0 = {p['c0']:g} (ours 10 U), rho0 = {p['rho0']:g} "
                f"(ours 1000).")
    if case == "poiseuille":
        return (f"{common} Non-dimensional: gap {p['length']:g}, nu {p['nu']:g}, force "
                f"{p['force']:.4g} from --re {_reynolds(case):g} (our Re); times x "
                f"{p['time_scale']:g} (viscous time); c0 = {p['c0'] / p['v_max']:g} v_max "
                f"(ours 200); example's width 0.4 gap; spacing module constant set to gap/n.")
    if case == "hydrostatic":
        return (f"{common} Module constants set to our tank (1 x 1 m water, g = 9.81, "
                f"5 s); c0 = 10 sqrt(gH) = {p['c0']:.3g} (ours: our wcsph's), linear EOS "
                f"(gamma 1), continuity density, artificial viscosity, gravity ramped in "
                f"over {p['gravity_ramp']:.3g} s (ours: none); Monaghan-Kajtar K scaled "
                f"with g H.")
    return (f"{common} Options --nx --re 100, tf {p['duration']:g} s, c0 = {p['c0']:g}, "
            f"rho0 = {p['rho0']:g}; velocities fitted within our h = "
            f"{interpolation_h(case, n):.3g} m over the fluid particles.")


def _child_env(threads: int, cache_dir: Path) -> dict[str, str]:
    env = dict(os.environ)
    env["OMP_NUM_THREADS"] = str(threads)
    env["HOME"] = str(cache_dir)  # PySPH compiles into ~/.pysph
    env.setdefault("MPLBACKEND", "Agg")
    return env


def _read_reports(stream, on_report: Callable[[str, dict], None], errors: list) -> None:
    """Hand each report line of the subprocess' stdout to on_report, to its end (an
    error of on_report is kept for the caller, and the pipe still drained)."""
    for line in stream:
        parts = line.rstrip("\n").split(" ", 2)
        if len(parts) != 3 or parts[0] != _TAG:
            continue  # the example's own prints
        try:
            fields = json.loads(parts[2])
        except ValueError:
            continue  # a line cut short by a kill
        if not errors:
            try:
                on_report(parts[1], fields)
            except Exception as e:  # re-raised by the caller, after the wait
                errors.append(e)
    stream.close()


def _kill_session(proc: subprocess.Popen) -> None:
    """SIGKILL to the subprocess' session (it leads it): the example and any compiler
    it started; nothing when all have ended."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    proc.wait()


def _run_child(command: list[str], workdir: str, env: dict[str, str], timeout: float | None,
               on_report: Callable[[str, dict], None]) -> tuple[int | None, str]:
    """Run the subprocess in a session of its own, handing its report lines to on_report
    as they come. Returns its exit code (None when it ran out of time) and its stderr.
    However the wait ends (done, timed out, Ctrl-C in the caller), the session is
    killed: no PySPH process outlives the call."""
    errors: list[Exception] = []
    with open(Path(workdir) / "stderr.txt", "w+", encoding="utf-8", errors="replace") as err:
        proc = subprocess.Popen(command, cwd=workdir, env=env, stdout=subprocess.PIPE,
                                stderr=err, text=True, start_new_session=True)
        reader = threading.Thread(target=_read_reports, args=(proc.stdout, on_report, errors),
                                  daemon=True)
        reader.start()
        code = None
        try:
            code = proc.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            pass
        finally:
            _kill_session(proc)
            reader.join()
        err.seek(0)
        stderr = err.read()
    if errors:
        raise errors[0]
    return code, stderr


def _where(start: dict, progress: dict) -> str:
    """How far a run that did not finish got: ' at 40 % of its simulated time'."""
    if not start:
        return " during its set-up"
    if not progress or start["t_end"] <= 0:
        return " before its first output"
    return f" at {100 * progress['t'] / start['t_end']:.0f} % of its simulated time"


def run_case(case: str, scheme: str, n: int, threads: int = 2,
             timeout: float | None = None, *, end_time: float | None = None,
             cache_dir: str | Path | None = None,
             progress: Callable[[float, float], None] | None = None) -> dict:
    """Run a PySPH example on one of our validation cases and score it as we do.

    Parameters
    ----------
    case, scheme : str
        A pair of :data:`PAIRS`.
    n : int
        Resolution: particles across the case's length scale (the box's side,
        the plate gap, the water depth, the cavity's side).
    threads : int
        OpenMP threads.
    timeout : float, optional
        Wall-clock seconds allowed for the subprocess (set-up and compilation
        included); by default none.
    end_time : float, optional
        The cavity's end time (default: ours, 30 s; at least 5 s): the error
        still averages the last 5 s. Not accepted for the other cases.
    cache_dir : path, optional
        HOME of the subprocess, where PySPH keeps its compiled kernels
        (``~/.pysph``); default :data:`CACHE_DIR`.
    progress : callable, optional
        Called at each output time of the run with the fraction of its simulated
        time done and the wall-clock seconds since it was started (from a thread
        that reads the subprocess' output).

    Returns
    -------
    dict
        ``peer`` ("pysph"), ``version``, ``case``, ``scheme``, ``n``, ``threads``,
        ``particles`` (fluid), ``steps``, ``wall_s`` (the time steps alone, timed
        in the subprocess, output writing excluded), ``cpu_s`` (CPU time of all
        threads over the same), ``setup_s`` (set-up and compilation), ``error``
        (our case's error; nan on failure), ``metrics`` (our case's further
        errors), ``failure`` ("" or why the run or its scoring failed, e.g.
        "timed out after 600 s at 40 % of its simulated time") and ``note`` (what
        ran, and how it differs from ours). A run that did not finish keeps the
        particles, steps and wall time it reported.

    Raises
    ------
    ValueError
        For an unknown (case, scheme), or a bad n, threads or end_time.
    """
    if (case, scheme) not in PAIRS:
        raise ValueError(f"no PySPH run for ({case!r}, {scheme!r}); expected one of "
                         f"{sorted(PAIRS)}")
    if n < 2 or threads < 1:
        raise ValueError(f"n must be >= 2 and threads >= 1 (got {n}, {threads})")
    if end_time is not None and (case != "cavity" or end_time < 5.0):
        raise ValueError("end_time is for the cavity only, and at least 5 s")
    result = {"peer": "pysph", "version": "", "case": case, "scheme": scheme, "n": n,
              "threads": threads, "particles": 0, "steps": 0, "wall_s": math.nan,
              "cpu_s": math.nan, "setup_s": math.nan, "error": math.nan, "metrics": {},
              "failure": "", "note": ""}
    if importlib.util.find_spec(PEER_MODULE) is None:
        result["failure"] = f"{PEER_MODULE} is not installed (pip install {REQUIREMENT})"
        return result
    from sphfluid.bench import exit_reason

    cache = Path(CACHE_DIR if cache_dir is None else cache_dir)
    cache.mkdir(parents=True, exist_ok=True)
    reports: dict[str, dict] = {}
    launched = time.perf_counter()

    def on_report(kind: str, fields: dict) -> None:
        reports[kind] = fields
        start = reports.get("start")
        if kind == "progress" and progress is not None and start and start["t_end"] > 0:
            progress(min(1.0, fields["t"] / start["t_end"]), time.perf_counter() - launched)

    with tempfile.TemporaryDirectory(prefix=f"sphfluid-pysph-{case}-") as workdir:
        config = Path(workdir) / "config.json"
        config.write_text(json.dumps(_child_config(case, scheme, n, workdir, end_time)),
                          encoding="utf-8")
        code, stderr = _run_child(_child_command(config), workdir,
                                  _child_env(threads, cache), timeout, on_report)
        start, last, done = (reports.get(k) for k in ("start", "progress", "done"))
        start, last = start or {}, last or {}
        result.update({k: start[k] for k in ("version", "particles", "setup_s") if k in start})
        result.update({k: last[k] for k in ("steps", "wall_s") if k in last})
        if code is None:
            result["failure"] = f"timed out after {timeout:g} s{_where(start, last)}"
            return result
        if code != 0 or done is None:
            how = exit_reason(code, stderr) if code != 0 else "ended without its report"
            result["failure"] = f"{how}{_where(start, last)}"
            return result
        result.update({k: done[k] for k in ("version", "particles", "steps", "wall_s",
                                            "cpu_s", "setup_s")})
        try:
            result["note"] = _note(case, scheme, n, done)
            snapshots = read_snapshots(workdir, done["times"])
            result.update(score(case, snapshots, n, done["params"]))
        except Exception as e:  # a run that cannot be scored is a failure, not a crash
            result["failure"] = f"scoring failed: {type(e).__name__}: {e}"
    return result


def _child_command(config: Path) -> list[str]:
    """This file run as the subprocess on a configuration file."""
    return [sys.executable, str(Path(__file__).resolve()), "--child", str(config)]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--list", action="store_true", help="print the (case, scheme) pairs")
    parser.add_argument("--case", choices=sorted({c for c, _ in PAIRS}))
    parser.add_argument("--scheme")
    parser.add_argument("--n", type=int, help="particles across the case's length scale")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--timeout", type=float, default=None, help="seconds")
    parser.add_argument("--end-time", type=float, default=None,
                        help="the cavity's end time in s (default 30)")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.child:
        _child(args.child)
        return 0
    if args.list:
        for case, scheme in PAIRS:
            print(case, scheme)
        return 0
    if args.case is None or args.scheme is None or args.n is None:
        parser.error("--case, --scheme and --n are required (or --list)")

    def progress(done: float, seconds: float) -> None:
        print(f"{100 * done:3.0f} % of the simulated time after {seconds:.0f} s",
              file=sys.stderr, flush=True)

    print(json.dumps(run_case(args.case, args.scheme, args.n, args.threads, args.timeout,
                              end_time=args.end_time, progress=progress)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
