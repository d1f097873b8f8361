"""Run established SPH codes on our benchmark dam break, for comparison.

The peers are PySPH (``pip install pysph``) and SPlisHSPlasH (``pip install
pysplishsplash``), both optional: :func:`available` says which can run here and why
the others cannot. :func:`run_peer` runs one of a peer's named configurations in a
subprocess (its driver, a script beside this file, given a configuration JSON file),
so that a crash or a hang in the peer cannot take down the caller, and returns its
speed and the error of its surge front against Martin & Moyce (1952), measured the
way our validation does.

The scene is ours (sphfluid.dam_break.GEOMETRY, as ``sphfluid bench`` and the
validation build it): a column a = 1 m wide and 2a high against the left wall of a
tank 4 m long and 3 m high, at rest at t = 0, the fluid on our lattice
((i + 1/2) dx, (j + 1/2) dx). Each peer keeps its own method (equation of state,
kernel, wall model, time step); :attr:`PeerResult.note` says which, and how it
differs from ours. See docs/peers.md.

``run_peer`` raises :class:`PeerUnavailableError` for a peer that cannot run; a peer
that crashes or times out part-way gives a result with :attr:`PeerResult.crashed`
set, its numbers measured up to the last sample it reported.

    python benchmarks/peers/peers.py --spacing 0.0141421356 --end-time 1.0 \\
        [--peer splishsplash] [--configuration wcsph-stiff]

prints a table (sphfluid must be importable: a source checkout's editable install).
"""
from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import subprocess
import sys
import tempfile
from collections.abc import Callable, Mapping
from ctypes.util import find_library
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from sphfluid.bench import exit_reason
from sphfluid.dam_break import GEOMETRY
from sphfluid.scene import load_scene
from sphfluid.simulation import speed_of_sound
from sphfluid.validation import reference as ref

__all__ = [
    "PEERS",
    "Configuration",
    "PeerResult",
    "PeerUnavailableError",
    "available",
    "configurations",
    "libgl_fix_env",
    "run_peer",
]

HERE = Path(__file__).resolve().parent  # the drivers live beside this file
SAMPLE_EVERY = 0.01  # s of simulated time between front samples, as our validation
IMPORT_TIMEOUT = 120.0  # s for the import probe of available()

_TAG = "@peer"  # prefix of the lines a peer's subprocess reports on stdout


def our_c0() -> float:
    """sphfluid's wcsph speed of sound for this scene [m/s]: 10 x the free-fall speed
    from the top of the column to the bottom of its domain (64.2 m/s)."""
    scene = GEOMETRY.scene(0.05, name="c0", fluid={},
                           solver={"method": "wcsph", "time_step": "auto"})
    return speed_of_sound(load_scene(scene))


def stiff_c0() -> float:
    """10 x Martin & Moyce's velocity scale sqrt(2 g a) [m/s] (44.3 m/s), where ours
    is 10 x the free fall from the column's top to the domain's floor."""
    return 10.0 * math.sqrt(2.0 * GEOMETRY.g * GEOMETRY.a)


class PeerUnavailableError(RuntimeError):
    """The peer is not installed, or importing it fails on this machine."""


@dataclass(frozen=True)
class PeerResult:
    """One peer's run of the dam break.

    Attributes
    ----------
    name : str
        The peer, one of :data:`PEERS`.
    configuration : str
        Its configuration's name, one of :func:`configurations` (name).
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
    configuration: str
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
# The peers and their configurations
# --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Configuration:
    """One way to run a peer on the dam break."""

    method: str  # the peer's solver, as it names it
    settings: Callable[[float], dict]  # spacing -> the driver's settings (its config file)
    note: Callable[[float], str]  # spacing -> what runs, and how it differs from ours


@dataclass(frozen=True)
class _Peer:
    module: str  # top-level module that find_spec looks for
    probe: str  # Python statement whose success means the peer can run
    requirement: str  # what to pip install
    driver: Path  # the script run in the subprocess
    configurations: Mapping[str, Configuration] = field(default_factory=dict)  # first: default
    libgl_fix: bool = False  # run with libgl_fix_env()


def _pysph_note(spacing: float) -> str:
    h = 1.3 * spacing
    g, a = GEOMETRY.g, GEOMETRY.a
    return (
        f"PySPH dam_break_2d example, scheme wcsph: Tait EOS gamma 7, c0 = "
        f"10 sqrt(2 g 2a) = {10 * math.sqrt(4 * g * a):.1f} m/s (ours {our_c0():.1f}), "
        f"Monaghan artificial viscosity alpha 0.1, Wendland quintic kernel h = 1.3 dx = "
        f"{h:.4g} m, PEC integrator, adaptive dt (0.125 h/c0 at start, ramped over 50 "
        f"steps), float64, OpenMP. Our geometry: fluid on our lattice, walls of 4 layers of "
        f"dummy particles spaced dx starting dx/2 outside x = 0, x = {GEOMETRY.tank:g} m and "
        f"y = 0 (the example: a 4 m high tank, fluid offset by dx); the example's particle "
        f"mass and h, which stay those of dx = 0.03 whatever --dx says, set to rho0 dx^2 and "
        f"1.3 dx."
    )


_SPLISHSPLASH_COMMON = (
    "cubic spline kernel with support 2 dx, standard viscosity 0.01, no vorticity "
    "model, walls by volume maps (Bender et al. 2019) on the tank's box mesh, float32. "
    "Fluid block shifted by -dx/2 so the particles sit on our lattice, dx/2 from the "
    "walls (a block put at the walls starts one spacing in). The first step, which "
    "builds the volume maps, is not timed. Solver parameters set through its Python "
    "API (without its GUI it ignores those in the scene file)."
)

# SPlisHSPlasH WCSPH's largest step with the stiff EOS below: about 0.4 (2 dx)/c0 at
# ~10,000 particles (dx = 0.0141 m), a cap its CFL rule needs, as that rule looks at the
# particles' speeds |v + a dt| and not at the speed of sound.
STIFF_MAX_DT = 2.5e-4  # s
STIFF_CFL_FACTOR = 0.5  # SPlisHSPlasH's default


def _tait(c0: float) -> dict:
    """SPlisHSPlasH WCSPH's equation of state p = B ((rho/rho0)^7 - 1), B = rho0 c0^2/7."""
    return {"stiffness": GEOMETRY.rho0 * c0**2 / 7.0, "exponent": 7.0}


def _wcsph_settings(spacing: float) -> dict:
    c0 = our_c0()
    return {"parameters": _tait(c0), "time_step": {"fixed": 0.3 * spacing / c0}}


def _wcsph_note(spacing: float) -> str:
    c0 = our_c0()
    return (
        f"SPlisHSPlasH WCSPH, our c0 and dt: Tait EOS gamma 7 with stiffness rho0 c0^2/7, "
        f"c0 = {c0:.1f} m/s as ours, negative pressure clamped to 0, fixed dt = 0.3 dx/c0 = "
        f"{0.3 * spacing / c0:.3g} s as our summed density's on its support of 2 dx (its "
        f"CFL rule ignores c0), symplectic Euler; "
        + _SPLISHSPLASH_COMMON
    )


def _stiff_settings(spacing: float) -> dict:
    return {"parameters": _tait(stiff_c0()),
            "time_step": {"cfl_factor": STIFF_CFL_FACTOR, "cfl_max": STIFF_MAX_DT}}


def _stiff_note(spacing: float) -> str:
    c0 = stiff_c0()
    return (
        f"SPlisHSPlasH WCSPH, stiff EOS and CFL steps: Tait EOS gamma 7 with stiffness "
        f"{_tait(c0)['stiffness']:,.0f} Pa (rho0 c0^2/7, c0 = 10 sqrt(2 g a) = {c0:.1f} m/s; "
        f"ours {our_c0():.1f}), negative pressure clamped to 0, its CFL rule (factor "
        f"{STIFF_CFL_FACTOR:g} on the largest |v + a dt|, no sound speed) with dt from its "
        f"minimum 1e-4 s to at most {STIFF_MAX_DT:g} s, symplectic Euler; "
        + _SPLISHSPLASH_COMMON
    )


def _dfsph_settings(spacing: float) -> dict:
    return {"parameters": {"minIterations": 2, "maxIterations": 100, "maxError": 0.1,
                           "maxIterationsV": 100, "maxErrorV": 0.1,
                           "enableDivergenceSolver": True},
            "time_step": {"cfl_factor": 1.0, "cfl_max": 0.005}}


def _dfsph_note(spacing: float) -> str:
    return ("SPlisHSPlasH DFSPH (divergence-free, implicit pressure): its dam-break "
            "settings, density error <= 0.1 %, CFL dt (factor 1, at most 5 ms); "
            + _SPLISHSPLASH_COMMON)


PEERS = ("pysph", "splishsplash")
_PEER_SPECS: dict[str, _Peer] = {
    "pysph": _Peer(
        module="pysph", probe="import pysph.examples.dam_break_2d",
        requirement="pysph==1.0b2", driver=HERE / "pysph_dam_break.py",
        configurations={"wcsph": Configuration("WCSPH", lambda spacing: {}, _pysph_note)}),
    "splishsplash": _Peer(
        module="pysplishsplash", probe="import pysplishsplash",
        requirement="pysplishsplash==2.19.0", driver=HERE / "splishsplash_dam_break.py",
        configurations={
            "wcsph": Configuration("WCSPH", _wcsph_settings, _wcsph_note),
            "wcsph-stiff": Configuration("WCSPH", _stiff_settings, _stiff_note),
            "dfsph": Configuration("DFSPH", _dfsph_settings, _dfsph_note),
        },
        libgl_fix=True),
}


def configurations(name: str) -> tuple[str, ...]:
    """The named configurations of a peer, its default first."""
    if name not in _PEER_SPECS:
        raise ValueError(f"unknown peer {name!r}; expected one of {', '.join(PEERS)}")
    return tuple(_PEER_SPECS[name].configurations)


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
        return f"`{peer.probe}` failed ({exit_reason(probe.returncode, probe.stderr)})"
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
             configuration: str | None = None, timeout: float = 3600.0) -> PeerResult:
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
    configuration : str, optional
        One of :func:`configurations` (name); by default the peer's first: PySPH
        "wcsph"; SPlisHSPlasH "wcsph" (our c0 and dt), "wcsph-stiff" (a stiffer
        EOS with its CFL steps) or "dfsph".
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
        For an unknown peer or configuration, or a non-positive spacing, end time or
        threads.
    PeerUnavailableError
        If the peer cannot run here (see :func:`available`).
    """
    names = configurations(name)
    peer = _PEER_SPECS[name]
    configuration = names[0] if configuration is None else configuration
    if configuration not in names:
        raise ValueError(f"{name} has no configuration {configuration!r}; expected one of "
                         f"{', '.join(names)}")
    if not (spacing > 0 and end_time > 0 and threads >= 1):
        raise ValueError(f"spacing, end_time and threads must be positive "
                         f"(got {spacing}, {end_time}, {threads})")
    reason = _unavailable_reason(peer)
    if reason is not None:
        raise PeerUnavailableError(f"{name}: {reason}")
    chosen = peer.configurations[configuration]
    with tempfile.TemporaryDirectory(prefix=f"sphfluid-peer-{name}-") as workdir:
        config_file = Path(workdir) / "config.json"
        config_file.write_text(json.dumps(
            _driver_config(chosen, spacing, end_time, workdir), indent=1), encoding="utf-8")
        command = [sys.executable, str(peer.driver), str(config_file)]
        try:
            proc = subprocess.run(command, check=False, cwd=workdir,
                                  env=_peer_env(peer, threads), capture_output=True,
                                  text=True, timeout=timeout)
            stdout, failure = proc.stdout, ""
            if proc.returncode != 0:
                failure = exit_reason(proc.returncode, proc.stderr)
        except subprocess.TimeoutExpired as exc:
            stdout = _as_text(exc.stdout)
            failure = f"timed out after {timeout:.0f} s"
    return _result(name, configuration, chosen.method, chosen.note(spacing), stdout, failure)


def _driver_config(chosen: Configuration, spacing: float, end_time: float,
                   workdir: str) -> dict:
    """What a driver reads: the geometry, the run, and the configuration's settings."""
    g = GEOMETRY
    return {
        "tag": _TAG, "workdir": workdir, "spacing": spacing, "end_time": end_time,
        "sample_every": SAMPLE_EVERY,
        # the column's lattice: ((i + 1/2) dx, (j + 1/2) dx), i < columns, j < rows
        "columns": math.floor(g.a / spacing + 0.5),
        "rows": math.floor(2.0 * g.a / spacing + 0.5),
        "tank": g.tank, "tank_height": g.tank_height, "g": g.g, "rho0": g.rho0,
        "method": chosen.method, **chosen.settings(spacing),
    }


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


def _result(name: str, configuration: str, method: str, note: str, stdout: str,
            failure: str) -> PeerResult:
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
    a = GEOMETRY.a
    front_t = (0.0, *(float(s["t"]) for s in samples))
    front_z = (a, *(float(s["z"]) for s in samples))
    try:
        error = ref.mean_front_error(np.array(front_t), np.array(front_z), a,
                                     max_z=GEOMETRY.tank / a)
    except ValueError as exc:
        error = math.nan
        note = f"{note} Front error n/a: {exc}."
    return PeerResult(
        name=name, configuration=configuration, method=start.get("method", method),
        version=start.get("version", ""), particles=particles, steps=steps, wall_s=wall,
        particle_steps_per_s=particles * steps / wall if wall > 0 else math.nan,
        front_error=error, crashed=crashed, note=note, front_t=front_t, front_z=front_z,
    )


# --------------------------------------------------------------------------------------
# Command line
# --------------------------------------------------------------------------------------


def _parser() -> argparse.ArgumentParser:
    every = sorted({c for spec in _PEER_SPECS.values() for c in spec.configurations})
    parser = argparse.ArgumentParser(prog="python benchmarks/peers/peers.py",
                                     description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--spacing", type=float, default=math.sqrt(2.0 / 10_000),
                        help="particle spacing dx in m (default: ~10,000 particles)")
    parser.add_argument("--end-time", type=float, default=1.0, help="simulated s")
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--peer", action="append", choices=PEERS,
                        help="peer to run (repeatable; default: all)")
    parser.add_argument("--configuration", action="append", choices=every,
                        help="configuration to run, of the peers that have it (repeatable; "
                             "default: each peer's first)")
    return parser


def main(argv: list[str] | None = None) -> int:
    """Run the available peers and print a table."""
    args = _parser().parse_args(argv)
    print(f"dam break, dx = {args.spacing:.5g} m, to t = {args.end_time} s, "
          f"{args.threads} thread(s)")
    print("| peer | configuration | method | particles | steps | wall s | ms/step "
          "| particle-steps/s | front error | crash |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---|")
    reasons = available()
    for name in args.peer or PEERS:
        if reasons[name] is not None:
            print(f"| {name} | skipped: {reasons[name]} ||||||||")
            continue
        own = configurations(name)
        for configuration in [c for c in args.configuration or own[:1] if c in own]:
            r = run_peer(name, spacing=args.spacing, end_time=args.end_time,
                         threads=args.threads, configuration=configuration)
            ms = 1000.0 * r.wall_s / r.steps if r.steps else math.nan
            print(f"| {r.name} {r.version} | {r.configuration} | {r.method} | "
                  f"{r.particles:,} | {r.steps:,} | {r.wall_s:.1f} | {ms:.2f} | "
                  f"{r.particle_steps_per_s / 1e6:.2f} M | {r.front_error:.3f} | "
                  f"{r.crashed or '-'} |", flush=True)
            print(f"\n{r.name} {r.configuration}: {r.note}\n", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
