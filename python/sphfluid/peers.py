"""Run established SPH codes on our benchmark dam break, for comparison.

The peers are PySPH (``pip install pysph``) and SPlisHSPlasH (``pip install
pysplishsplash``), both optional: :func:`available` says which can run here and why
the others cannot. :func:`run_peer` runs one in a subprocess, so that a crash or a
hang in the peer cannot take down the caller, and returns its speed and the error of
its surge front against Martin & Moyce (1952), measured the way our validation does.

The scene is ours (``sphfluid bench`` and the validation's dam break): a column
a = 1 m wide and 2a high against the left wall of a tank 4 m long and 3 m high,
g = 9.81 m/s^2, rho0 = 1000 kg/m^3, at rest at t = 0, the fluid on our lattice
((i + 1/2) dx, (j + 1/2) dx). Each peer keeps its own method (equation of state,
kernel, wall model, time step); :attr:`PeerResult.note` says which, and how it
differs from ours. See docs/peers.md.

``run_peer`` raises :class:`PeerUnavailableError` for a peer that cannot run; a peer
that crashes or times out part-way gives a result with :attr:`PeerResult.crashed`
set, its numbers measured up to the last sample it reported.

``python -m sphfluid.peers --spacing 0.0141 --end-time 1.0`` prints a table.
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import signal
import subprocess
import sys
import tempfile
from collections.abc import Callable, Mapping
from ctypes.util import find_library
from dataclasses import dataclass

import numpy as np

from .validation import reference as ref

__all__ = [
    "PEERS",
    "PeerResult",
    "PeerUnavailableError",
    "available",
    "libgl_fix_env",
    "run_peer",
]

# The dam break (ours): column a x 2a at the left of a TANK x TANK_HEIGHT tank.
A = 1.0  # m
TANK = 4.0  # m
TANK_HEIGHT = 3.0  # m
G = 9.81  # m/s^2
RHO0 = 1000.0  # kg/m^3
# sphfluid's wcsph speed of sound for this scene: 10 x the free-fall speed from the top
# of the column to the bottom of its domain (y = -0.1 m); SPlisHSPlasH's WCSPH uses it.
C0 = 10.0 * math.sqrt(2.0 * G * (2.0 * A + 0.1))
SAMPLE_EVERY = 0.01  # s of simulated time between front samples, as our validation
IMPORT_TIMEOUT = 120.0  # s for the import probe of available()

_TAG = "@peer"  # prefix of the lines a peer's subprocess reports on stdout


class PeerUnavailableError(RuntimeError):
    """The peer is not installed, or importing it fails on this machine."""


@dataclass(frozen=True)
class PeerResult:
    """One peer's run of the dam break.

    Attributes
    ----------
    name : str
        The peer, one of :data:`PEERS`.
    method : str
        Its solver, e.g. ``"WCSPH"``.
    version : str
        The peer's version.
    particles : int
        Fluid particles (0 when the peer failed before creating them).
    steps : int
        Time steps timed.
    wall_s : float
        Wall-clock seconds of those steps alone: setup, compilation and the front
        samples are excluded.
    particle_steps_per_s : float
        ``particles * steps / wall_s`` (nan without timed steps).
    front_error : float
        Mean |Z_sim - Z_MM| of Z = z/a against Martin & Moyce (1952) Table 2 at
        T = t sqrt(2g/a), over the points with Z < 4 that the run reached, no time
        shift (:func:`sphfluid.validation.reference.mean_front_error`); nan when the
        run covered fewer than 3 of them.
    crashed : str
        Why the run stopped early ("" when it reached the end time).
    note : str
        The peer's configuration and how it differs from ours.
    front_t, front_z : tuple of float
        The front history the error is computed from: times [s], from 0, and front
        positions [m], starting at a.
    """

    name: str
    method: str
    version: str
    particles: int
    steps: int
    wall_s: float
    particle_steps_per_s: float
    front_error: float
    crashed: str
    note: str
    front_t: tuple[float, ...]
    front_z: tuple[float, ...]


# --------------------------------------------------------------------------------------
# What runs in a peer's subprocess: the shared part, then one script per peer. Each is
# run as `python -c SCRIPT CONFIG_JSON` and reports on stdout, one line each:
#   @peer start  {"method", "version", "particles"}
#   @peer sample {"t", "z", "steps", "wall"}   every SAMPLE_EVERY s of simulated time
#   @peer done   {"t", "steps", "wall"}
# `steps` and `wall` count the timed steps so far, so a crash keeps what was reached.
# --------------------------------------------------------------------------------------

_CHILD_COMMON = r'''
import json, sys, time
from importlib.metadata import version
import numpy as np

CFG = json.loads(sys.argv[1])
DX = CFG["spacing"]


def emit(kind, **fields):
    print(CFG["tag"], kind, json.dumps(fields), flush=True)


def surge_front(pos):
    """Rightmost particle with at least two others within 2 dx, plus dx/2."""
    if not np.all(np.isfinite(pos)):
        raise RuntimeError("non-finite particle positions")
    order = np.argsort(pos[:, 0])[::-1]
    for i in order[:200]:
        if np.count_nonzero(((pos - pos[i]) ** 2).sum(1) < (2 * DX) ** 2) >= 3:
            return float(pos[i, 0] + DX / 2)
    return float(pos[order[0], 0] + DX / 2)


class Recorder:
    """Counts and times steps; samples the front between them, off the clock."""

    def __init__(self):
        self.steps = 0
        self.wall = 0.0
        self.next_sample = CFG["sample_every"]
        self.started = time.perf_counter()

    def step(self, t, positions):
        """Call after each step, with the time reached and a positions (n, 2) getter."""
        self.steps += 1
        if t < self.next_sample - 1e-9:
            return
        self.wall += time.perf_counter() - self.started
        emit("sample", t=float(t), z=surge_front(positions()), steps=self.steps,
             wall=self.wall)
        while self.next_sample <= t + 1e-9:
            self.next_sample += CFG["sample_every"]
        self.started = time.perf_counter()

    def finish(self, t):
        self.wall += time.perf_counter() - self.started
        emit("done", t=float(t), steps=self.steps, wall=self.wall)
'''

_PYSPH_SCRIPT = _CHILD_COMMON + r'''
from pysph.base.utils import get_particle_array
from pysph.examples.dam_break_2d import DamBreak2D

LAYERS = 4  # boundary particle layers, as the example's non-staggered tank


def fluid_lattice():
    """Our column's particles: ((i + 1/2) dx, (j + 1/2) dx) inside a x 2a."""
    nx, ny = CFG["columns"], CFG["rows"]
    x, y = np.meshgrid((np.arange(nx) + 0.5) * DX, (np.arange(ny) + 0.5) * DX)
    return x.ravel(), y.ravel()


def tank_particles():
    """Dummy wall particles on our lattice, LAYERS deep outside x = 0, x = L, y = 0."""
    out = -(np.arange(LAYERS) + 0.5) * DX
    inside_x = (np.arange(int(CFG["tank"] / DX + 0.5)) + 0.5) * DX
    inside_y = (np.arange(int(CFG["tank_height"] / DX + 0.5)) + 0.5) * DX
    cols = np.concatenate([out, inside_x[inside_x < CFG["tank"]], CFG["tank"] - out])
    rows = np.concatenate([out, inside_y[inside_y < CFG["tank_height"]]])
    x, y = np.meshgrid(cols, rows)
    wall = (x < 0) | (x > CFG["tank"]) | (y < 0)
    return x[wall], y[wall]


class Peer(DamBreak2D):
    """The example with our geometry, and mass and h taken from --dx."""

    def create_particles(self):
        mass = CFG["rho0"] * DX * DX
        xf, yf = fluid_lattice()
        xb, yb = tank_particles()
        fluid = get_particle_array(name="fluid", x=xf, y=yf, h=self.h, m=mass, rho=CFG["rho0"])
        boundary = get_particle_array(name="boundary", x=xb, y=yb, h=self.h, m=mass,
                                      rho=CFG["rho0"])
        self.scheme.setup_properties([fluid, boundary])
        self.fluid = fluid
        return [fluid, boundary]

    def post_step(self, solver):
        # called before the solver advances t by dt
        recorder.step(solver.t + solver.dt, lambda: np.column_stack((self.fluid.x, self.fluid.y)))


app = Peer(fname="dam_break_peer", output_dir=CFG["workdir"])
app.setup(["--scheme", "wcsph", "--dx", repr(DX), "--tf", repr(CFG["end_time"]), "--openmp",
           "--disable-output", "--quiet", "--directory", CFG["workdir"]])
emit("start", method="WCSPH", version=version("pysph"),
     particles=int(app.fluid.get_number_of_particles()))
recorder = Recorder()
app.solver.solve(False)
recorder.finish(app.solver.t)
'''

_SPLISHSPLASH_SCRIPT = _CHILD_COMMON + r'''
import os
import pysplishsplash as sph

METHOD_IDS = {"WCSPH": 0, "DFSPH": 4}  # SPlisHSPlasH's simulationMethod enumeration


def write_tank(path):
    """The tank as a closed box mesh, x 0..L, y 0..H (z is flattened in 2D)."""
    L, H = CFG["tank"], CFG["tank_height"]
    corners = [(x, y, z) for z in (0.5, -0.5) for y in (0.0, H) for x in (0.0, L)]
    faces = [(1, 2, 3), (3, 2, 4), (5, 7, 6), (6, 7, 8), (1, 3, 5), (5, 3, 7),
             (2, 6, 4), (4, 6, 8), (1, 5, 2), (2, 5, 6), (3, 4, 7), (7, 4, 8)]
    with open(path, "w") as f:
        f.writelines(f"v {x} {y} {z}\n" for x, y, z in corners)
        f.writelines(f"f {a} {b} {c}\n" for a, b, c in faces)


def scene():
    config = {"pause": False, "sim2D": True, "particleRadius": DX / 2,
              "simulationMethod": METHOD_IDS[CFG["method"]],
              "gravitation": [0.0, -CFG["g"], 0.0], "boundaryHandlingMethod": 2,
              "stopAt": CFG["end_time"], "enableZSort": True}
    if CFG["method"] == "WCSPH":  # our fixed dt: SPlisHSPlasH's CFL rule ignores c0
        config.update({"cflMethod": 0, "timeStepSize": CFG["dt"]})
    else:  # SPlisHSPlasH's dam-break settings
        config.update({"cflMethod": 1, "cflFactor": 1.0, "cflMaxTimeStepSize": 0.005})
    tank = os.path.join(CFG["workdir"], "tank.obj")
    write_tank(tank)
    nx, ny = CFG["columns"], CFG["rows"]
    return {
        "Configuration": config,
        "Materials": [{"id": "Fluid", "density0": CFG["rho0"], "viscosityMethod": 1,
                       "viscosity": 0.01, "vorticityMethod": 0}],
        "RigidBodies": [{"geometryFile": tank, "isDynamic": False, "isWall": True,
                         "mapInvert": True, "mapThickness": 0.0,
                         # cells about one kernel support (2 dx) wide
                         "mapResolution": [int(np.ceil(CFG["tank"] / (2 * DX))),
                                           int(np.ceil(CFG["tank_height"] / (2 * DX))), 1]}],
        # a block's first particle sits one spacing in from its corner: start half a
        # spacing outside the tank so that the particles land on our lattice
        "FluidBlocks": [{"denseMode": 0, "start": [-DX / 2, -DX / 2, -0.5],
                         "end": [(nx + 0.5) * DX, (ny + 0.5) * DX, 0.5]}],
    }


def solver_parameters():
    if CFG["method"] == "WCSPH":  # Tait EOS with our c0
        return {"stiffness": CFG["rho0"] * CFG["c0"] ** 2 / 7.0, "exponent": 7.0}
    return {"minIterations": 2, "maxIterations": 100, "maxError": 0.1,  # % density error
            "maxIterationsV": 100, "maxErrorV": 0.1, "enableDivergenceSolver": True}


def set_parameters(obj, values):
    """Set parameters of obj by name and check that they took.

    Without its GUI, SPlisHSPlasH 2.19 does not read the solver's parameters (e.g.
    the WCSPH stiffness) from the scene file: it would run with its defaults.
    """
    took = {}
    for i in range(obj.numParameters()):
        name = obj.getName(i)
        if name not in values:
            continue
        kind = str(obj.getType(i))
        if "BOOL" in kind:
            set_value, get_value = obj.setValueBool, obj.getValueBool
        elif "UINT" in kind:
            set_value, get_value = obj.setValueUInt, obj.getValueUInt
        elif "INT" in kind:
            set_value, get_value = obj.setValueInt, obj.getValueInt
        else:
            set_value, get_value = obj.setValueFloat, obj.getValueFloat
        set_value(i, values[name])
        took[name] = get_value(i)
    wrong = {k: took.get(k) for k, v in values.items()
             if k not in took or not np.isclose(took[k], v, rtol=1e-6)}
    if wrong:
        raise RuntimeError(f"SPlisHSPlasH did not take the solver parameters {wrong}")


path = os.path.join(CFG["workdir"], "dam_break.json")
with open(path, "w") as f:
    json.dump(scene(), f)
base = sph.Exec.SimulatorBase()
base.init(sceneFile=path, useGui=False, outputDir=os.path.join(CFG["workdir"], "output"),
          initialPause=False, useCache=False, stopAt=CFG["end_time"])
base.initSimulation()
set_parameters(sph.Simulation.getCurrent().getTimeStep(), solver_parameters())
model = sph.Simulation.getCurrent().getFluidModel(0)
clock = sph.TimeManager.getCurrent()
n = model.numActiveParticles()
emit("start", method=CFG["method"], version=version("pysplishsplash"), particles=n)
# runSimulation() initialises the boundary (volume maps) and takes at least one step:
# let it take exactly one, untimed, then step on here.
base.setValueFloat(base.STOP_AT, 1e-12)
base.runSimulation()
base.setValueFloat(base.STOP_AT, CFG["end_time"])
recorder = Recorder()
while base.timeStepNoGUI():
    recorder.step(clock.getTime(),
                  lambda: np.asarray(model.getFieldBuffer("position"))[:n, :2].astype(float))
recorder.finish(clock.getTime())
base.cleanup()
'''


# --------------------------------------------------------------------------------------
# The peers
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Peer:
    module: str  # top-level module that find_spec looks for
    probe: str  # Python statement whose success means the peer can run
    requirement: str  # what to pip install
    methods: tuple[str, ...]  # the first is the default
    script: str
    note: Callable[[str, float], str]  # (method, spacing) -> configuration note
    libgl_fix: bool = False  # run with libgl_fix_env()


def _pysph_note(method: str, spacing: float) -> str:
    h = 1.3 * spacing
    return (
        f"PySPH dam_break_2d example, scheme wcsph: Tait EOS gamma 7, c0 = "
        f"10 sqrt(2 g 2a) = {10 * math.sqrt(4 * G * A):.1f} m/s (ours {C0:.1f}), Monaghan "
        f"artificial viscosity alpha 0.1, Wendland quintic kernel h = 1.3 dx = {h:.4g} m, "
        f"PEC integrator, adaptive dt (0.125 h/c0 at start, ramped over 50 steps), "
        f"float64, OpenMP. Our geometry: fluid on our lattice, walls of 4 layers of dummy "
        f"particles spaced dx starting dx/2 outside x = 0, x = 4 m and y = 0 (the example: "
        f"a 4 m high tank, fluid offset by dx); the example's particle mass and h, which "
        f"stay those of dx = 0.03 whatever --dx says, set to rho0 dx^2 and 1.3 dx."
    )


def _splishsplash_note(method: str, spacing: float) -> str:
    common = (
        "cubic spline kernel with support 2 dx, standard viscosity 0.01, no vorticity "
        "model, walls by volume maps (Bender et al. 2019) on the tank's box mesh, float32. "
        "Fluid block shifted by -dx/2 so the particles sit on our lattice, dx/2 from the "
        "walls (a block put at the walls starts one spacing in). The first step, which "
        "builds the volume maps, is not timed. Solver parameters set through its Python "
        "API (without its GUI it ignores those in the scene file)."
    )
    if method == "WCSPH":
        dt = 0.3 * spacing / C0
        return (
            f"SPlisHSPlasH WCSPH: Tait EOS gamma 7 with stiffness rho0 c0^2/7, c0 = "
            f"{C0:.1f} m/s as ours, negative pressure clamped to 0, fixed dt = 0.3 dx/c0 = "
            f"{dt:.3g} s as ours (its CFL rule ignores c0), symplectic Euler; " + common
        )
    return (
        "SPlisHSPlasH DFSPH (divergence-free, implicit pressure): its dam-break settings, "
        "density error <= 0.1 %, CFL dt (factor 1, at most 5 ms); " + common
    )


PEERS = ("pysph", "splishsplash")
_PEER_SPECS: dict[str, _Peer] = {
    "pysph": _Peer(module="pysph", probe="import pysph.examples.dam_break_2d",
                   requirement="pysph==1.0b2", methods=("WCSPH",), script=_PYSPH_SCRIPT,
                   note=_pysph_note),
    "splishsplash": _Peer(module="pysplishsplash", probe="import pysplishsplash",
                          requirement="pysplishsplash==2.19.0", methods=("WCSPH", "DFSPH"),
                          script=_SPLISHSPLASH_SCRIPT, note=_splishsplash_note,
                          libgl_fix=True),
}


def libgl_fix_env(base: Mapping[str, str] | None = None) -> dict[str, str]:
    """An environment in which the pysplishsplash wheel can be imported.

    The wheel bundles its own libGLX, libGLdispatch and libOpenGL (renamed by
    auditwheel) but also links the system's libGL, which loads the system's copies:
    with two libGLdispatch in one process the import crashes (SIGSEGV). Preloading
    the system's libraries makes every GL symbol resolve to them. Only the libraries
    the system has are preloaded (none: nothing to fix); ``LD_PRELOAD`` entries
    already in ``base`` are kept after them.

    Parameters
    ----------
    base : mapping, optional
        The environment to start from; by default ``os.environ`` (never modified).

    Returns
    -------
    dict
        A copy of ``base`` with ``LD_PRELOAD`` set, for a subprocess.
    """
    env = dict(os.environ if base is None else base)
    libs = [lib for lib in (find_library(n) for n in ("GLdispatch", "GLX", "OpenGL")) if lib]
    if env.get("LD_PRELOAD"):
        libs.append(env["LD_PRELOAD"])
    if libs:
        env["LD_PRELOAD"] = ":".join(libs)
    return env


def _peer_env(peer: _Peer, threads: int) -> dict[str, str]:
    env = libgl_fix_env() if peer.libgl_fix else dict(os.environ)
    env["OMP_NUM_THREADS"] = str(threads)
    return env


def _exit_reason(returncode: int, stderr: str) -> str:
    """'killed by SIGSEGV' or 'exit code 1', and the last line of stderr if any."""
    if returncode < 0:
        try:
            how = f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            how = f"killed by signal {-returncode}"
    else:
        how = f"exit code {returncode}"
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    return f"{how}: {lines[-1][:300]}" if lines else how


def _unavailable_reason(peer: _Peer) -> str | None:
    if importlib.util.find_spec(peer.module) is None:
        return f"not installed (pip install {peer.requirement}; see docs/peers.md)"
    try:
        probe = subprocess.run([sys.executable, "-c", peer.probe], check=False,
                               env=_peer_env(peer, 1), capture_output=True, text=True,
                               timeout=IMPORT_TIMEOUT)
    except subprocess.TimeoutExpired:
        return f"`{peer.probe}` did not finish in {IMPORT_TIMEOUT:.0f} s"
    if probe.returncode != 0:
        return f"`{peer.probe}` failed ({_exit_reason(probe.returncode, probe.stderr)})"
    return None


def available() -> dict[str, str | None]:
    """Which peers can run here.

    Each peer is imported in a subprocess (with its environment fixes), so a peer
    that crashes on import cannot crash the caller.

    Returns
    -------
    dict
        For each name in :data:`PEERS`: None if it can run, else a one-line reason
        it is skipped (not installed, or the import failed and how).
    """
    return {name: _unavailable_reason(_PEER_SPECS[name]) for name in PEERS}


# --------------------------------------------------------------------------------------
# Running a peer
# --------------------------------------------------------------------------------------


def run_peer(name: str, *, spacing: float, end_time: float, threads: int = 2,
             method: str | None = None, timeout: float = 3600.0) -> PeerResult:
    """Run a peer on our dam break and measure its speed and front error.

    Parameters
    ----------
    name : str
        One of :data:`PEERS`.
    spacing : float
        Particle spacing dx [m]; the column gets about (a/dx)(2a/dx) particles, e.g.
        10,011 at dx = 0.01414.
    end_time : float
        Simulated time [s] to run to (1.0 for the benchmark).
    threads : int
        OpenMP threads of the peer (``OMP_NUM_THREADS``).
    method : str, optional
        The peer's solver: "WCSPH" (default) for both; SPlisHSPlasH also "DFSPH".
    timeout : float
        Wall-clock seconds allowed for the whole subprocess, setup included
        (PySPH compiles its kernels on the first run with a new configuration).

    Returns
    -------
    PeerResult
        With ``crashed`` set if the peer died, failed or timed out before the end
        time; its numbers then cover the run up to its last sample.

    Raises
    ------
    ValueError
        For an unknown peer or method, or a non-positive spacing, end time or threads.
    PeerUnavailableError
        If the peer cannot run here (see :func:`available`).
    """
    if name not in _PEER_SPECS:
        raise ValueError(f"unknown peer {name!r}; expected one of {', '.join(PEERS)}")
    peer = _PEER_SPECS[name]
    method = peer.methods[0] if method is None else method
    if method not in peer.methods:
        raise ValueError(f"{name} has no method {method!r}; expected one of "
                         f"{', '.join(peer.methods)}")
    if not (spacing > 0 and end_time > 0 and threads >= 1):
        raise ValueError(f"spacing, end_time and threads must be positive "
                         f"(got {spacing}, {end_time}, {threads})")
    reason = _unavailable_reason(peer)
    if reason is not None:
        raise PeerUnavailableError(f"{name}: {reason}")

    config = {
        "tag": _TAG, "method": method, "spacing": spacing, "end_time": end_time,
        "columns": math.floor(A / spacing + 0.5),
        "rows": math.floor(2.0 * A / spacing + 0.5),
        "tank": TANK, "tank_height": TANK_HEIGHT, "g": G, "rho0": RHO0, "c0": C0,
        "dt": 0.3 * spacing / C0, "sample_every": SAMPLE_EVERY,
    }
    with tempfile.TemporaryDirectory(prefix=f"sphfluid-peer-{name}-") as workdir:
        config["workdir"] = workdir
        command = [sys.executable, "-c", peer.script, json.dumps(config)]
        try:
            proc = subprocess.run(command, check=False, cwd=workdir,
                                  env=_peer_env(peer, threads), capture_output=True,
                                  text=True, timeout=timeout)
            stdout, failure = proc.stdout, ""
            if proc.returncode != 0:
                failure = _exit_reason(proc.returncode, proc.stderr)
        except subprocess.TimeoutExpired as exc:
            stdout = _as_text(exc.stdout)
            failure = f"timed out after {timeout:.0f} s"
    return _result(name, method, peer.note(method, spacing), stdout, failure)


def _as_text(output: bytes | str | None) -> str:
    if isinstance(output, bytes):
        return output.decode(errors="replace")
    return output or ""


def _reports(stdout: str) -> list[tuple[str, dict]]:
    """The (kind, fields) reports in a peer's stdout, in order."""
    out = []
    for line in stdout.splitlines():
        parts = line.split(" ", 2)
        if len(parts) == 3 and parts[0] == _TAG:
            out.append((parts[1], json.loads(parts[2])))
    return out


def _result(name: str, method: str, note: str, stdout: str, failure: str) -> PeerResult:
    start: dict = {}
    samples: list[dict] = []
    done: dict | None = None
    for kind, fields in _reports(stdout):
        if kind == "start":
            start = fields
        elif kind == "sample":
            samples.append(fields)
        elif kind == "done":
            done = fields
    last = done if done is not None else (samples[-1] if samples else {})
    if done is None:
        where = f" at t = {last['t']:.3f} s" if last else " before its first sample"
        crashed = f"{failure or 'stopped without finishing'}{where}"
    else:
        crashed = f"{failure} (after the run had finished)" if failure else ""
    particles = int(start.get("particles", 0))
    steps = int(last.get("steps", 0))
    wall = float(last.get("wall", 0.0))
    front_t = (0.0, *(float(s["t"]) for s in samples))
    front_z = (A, *(float(s["z"]) for s in samples))
    try:
        error = ref.mean_front_error(np.array(front_t), np.array(front_z), A, max_z=TANK / A)
    except ValueError as exc:
        error = math.nan
        note = f"{note} Front error n/a: {exc}."
    return PeerResult(
        name=name, method=start.get("method", method), version=start.get("version", ""),
        particles=particles, steps=steps, wall_s=wall,
        particle_steps_per_s=particles * steps / wall if wall > 0 else math.nan,
        front_error=error, crashed=crashed, note=note, front_t=front_t, front_z=front_z,
    )


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    """``python -m sphfluid.peers``: run the available peers and print a table."""
    parser = argparse.ArgumentParser(prog="python -m sphfluid.peers", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--spacing", type=float, default=math.sqrt(2.0 / 10_000),
                        help="particle spacing dx in m (default: ~10,000 particles)")
    parser.add_argument("--end-time", type=float, default=1.0, help="simulated s")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--peer", action="append", choices=PEERS,
                        help="peer to run (repeatable; default: all)")
    parser.add_argument("--method", help="the peers' solver (default: each one's first)")
    args = parser.parse_args(argv)
    print(f"dam break, dx = {args.spacing:.5g} m, to t = {args.end_time} s, "
          f"{args.threads} thread(s)")
    print("| peer | method | particles | steps | wall s | ms/step | particle-steps/s "
          "| front error | crash |")
    print("|---|---|---:|---:|---:|---:|---:|---:|---|")
    reasons = available()
    for name in args.peer or PEERS:
        if reasons[name] is not None:
            print(f"| {name} | skipped: {reasons[name]} |||||||")
            continue
        r = run_peer(name, spacing=args.spacing, end_time=args.end_time,
                     threads=args.threads, method=args.method)
        ms = 1000.0 * r.wall_s / r.steps if r.steps else math.nan
        print(f"| {r.name} {r.version} | {r.method} | {r.particles:,} | {r.steps:,} | "
              f"{r.wall_s:.1f} | {ms:.2f} | {r.particle_steps_per_s / 1e6:.2f} M | "
              f"{r.front_error:.3f} | {r.crashed or '-'} |")
        print(f"\n{r.name}: {r.note}\n", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
