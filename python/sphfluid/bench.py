"""`sphfluid bench`: the dam break at about N particles, fixed dt, timed on 1 and 2
threads. Prints steps/s, particle-steps/s and per-phase times next to the
accuracy of the same run, and our steps/s as a multiple of a plain reference
loop's (benchmarks/reference_loop.cpp, from a source checkout's benchmarks/
folder, which this module also finds and imports from); can write the table
into a Markdown file.
"""
from __future__ import annotations

import datetime
import importlib.util
import math
import os
import platform
import signal
import statistics
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import numpy as np

from . import _core
from .dam_break import GEOMETRY
from .metadata import target
from .simulation import Simulation


# The repository's benchmarks/ folder (peer drivers, reference loop): not in the wheel.
BENCHMARKS_ENV = "SPHFLUID_BENCHMARKS"


class BenchmarksNotFoundError(RuntimeError):
    """No benchmarks/ folder: an installed wheel, or a wrong --benchmarks-dir."""


def benchmarks_dir(explicit: Path | None = None) -> Path:
    """The repository's benchmarks/ folder: `explicit` (--benchmarks-dir), else
    $SPHFLUID_BENCHMARKS, else beside the package of a source checkout (an editable
    install runs the package from <repo>/python/sphfluid), else in the current
    folder (a checkout's root, with the package installed from it).

    Raises BenchmarksNotFoundError, saying where it looked, when there is none.
    """
    if explicit is not None or os.environ.get(BENCHMARKS_ENV):
        given = Path(explicit if explicit is not None else os.environ[BENCHMARKS_ENV])
        how = "--benchmarks-dir" if explicit is not None else f"${BENCHMARKS_ENV}"
        if not given.is_dir():
            raise BenchmarksNotFoundError(f"{how} {given} is not a folder")
        return given
    beside = Path(__file__).resolve().parent.parent.parent / "benchmarks"
    here = Path.cwd() / "benchmarks"
    for candidate in (beside, here):
        if (candidate / "peers").is_dir():
            return candidate
    raise BenchmarksNotFoundError(
        "no benchmarks/ folder: it is in a source checkout of sphfluid, not in the wheel "
        f"(looked in {beside} and {here}); run from the checkout's root or give it with "
        f"--benchmarks-dir DIR or ${BENCHMARKS_ENV}")


def load_benchmark(benchmarks: Path, relative: str) -> ModuleType:
    """Import a Python file of benchmarks/ (e.g. "peers/peers.py") as a module, once
    per file: a second call returns the module the first one loaded."""
    path = (Path(benchmarks) / relative).resolve()
    if not path.is_file():
        raise BenchmarksNotFoundError(f"{path} is missing")
    name = "sphfluid_benchmarks_" + relative.removesuffix(".py").replace("/", "_")
    loaded = sys.modules.get(name)
    if loaded is not None and Path(loaded.__file__).resolve() == path:
        return loaded
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module  # dataclasses look their module up while it executes
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[name]
        raise
    return module


def exit_reason(returncode: int, stderr: str) -> str:
    """How a peer's subprocess ended, for a report: 'killed by SIGSEGV' or 'exit code
    1', and the last line of its stderr if any (the peer drivers of benchmarks/)."""
    if returncode < 0:
        try:
            how = f"killed by {signal.Signals(-returncode).name}"
        except ValueError:
            how = f"killed by signal {-returncode}"
    else:
        how = f"exit code {returncode}"
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    return f"{how}: {lines[-1][:300]}" if lines else how


def dam_break_scene(n_target: int, method: str = "seed") -> dict:
    """The bundled dam break (1 x 2 m column, 4 m tank) at about n_target particles.

    dt scales with the spacing (a fixed CFL number), so every N runs the same
    physics: dt = 0.0002 s at dx = 0.02 m for the seed; for wcsph 0.3 (h/2)/c0
    with its default support h. dfsph runs water (its viscosity, 1e-3 Pa s) with
    its own adaptive step: the flow's CFL condition, no sound speed.
    """
    dx = math.sqrt(2.0 / n_target)
    fluid = {"viscosity": 1e-3} if method == "dfsph" else {"gas_constant": 250.0,
                                                           "viscosity": 30.0}
    scene = GEOMETRY.scene(dx, name=f"Dam break, {n_target:,} particles", fluid=fluid,
                           solver={"method": method, "time_step": 0.0002 * dx / 0.02})
    if method == "wcsph":  # a fixed step within its CFL limit: 0.3 (h/2) / c0
        from .scene import load_scene
        from .simulation import speed_of_sound

        loaded = load_scene(scene)
        scene["solver"]["time_step"] = 0.15 * loaded.smoothing_length / speed_of_sound(loaded)
    elif method == "dfsph":
        scene["solver"]["time_step"] = "auto"
    return scene


# What the suite times: the methods, and the seed with its pair forces in float
# (solver.pair_precision).
VARIANTS = ("seed", "wcsph", "seed-float", "dfsph")


def variant_scene(n_target: int, variant: str) -> dict:
    """dam_break_scene for a method or for "seed-float"."""
    scene = dam_break_scene(n_target, "seed" if variant == "seed-float" else variant)
    if variant == "seed-float":
        scene["solver"]["pair_precision"] = "float"
    return scene


def front_error(sim: Simulation, a: float = 1.0) -> tuple[float, float, float]:
    """(T, simulated Z, Martin & Moyce's Table 2 Z at that T, with Z(0) = 1): the
    surge front of the validation suite (spray skipped) at the time reached."""
    from .validation.cases import surge_front
    from .validation.reference import front_time_scale, martin_moyce

    mm = martin_moyce("front")
    t_star = sim.time * front_time_scale(a)
    z = surge_front(sim.positions, sim.scene.spacing) / a
    return t_star, z, float(np.interp(t_star, np.r_[0.0, mm.x], np.r_[1.0, mm.y]))


def guard_cost(n_target: int, steps: int, repeats: int) -> dict:
    """Step time with and without the guard's checks, interleaved runs on 1 thread."""
    import statistics

    from . import simulation

    walls: dict[bool, list[float]] = {True: [], False: []}
    phase: dict[bool, list[float]] = {True: [], False: []}
    for _ in range(repeats):
        for on in (True, False):
            sim = Simulation(dam_break_scene(n_target), threads=1)
            params = simulation._params(sim.scene, 1)
            params.guard = on
            pos, vel = sim.scene.lattice_points()
            sim._solver = _core.Solver(params, pos, vel, simulation._wall_array(sim.scene))
            sim.step(50)
            sim._solver.reset_phase_seconds()
            start = time.perf_counter()
            sim.step(steps)
            walls[on].append((time.perf_counter() - start) / steps)
            phase[on].append(sim._solver.phase_seconds()["integrate"] / steps)
    med = {k: statistics.median(v) for k, v in walls.items()}
    ph = {k: statistics.median(v) for k, v in phase.items()}
    return {"step_on": med[True], "step_off": med[False], "integrate_on": ph[True],
            "integrate_off": ph[False],
            "cost_fraction": (ph[True] - ph[False]) / med[True]}


def draw_times(n_target: int, frames: int, size: tuple[int, int] = (1000, 700)) -> dict:
    """Milliseconds to draw one frame of the dam break in each colour mode (headless)."""
    import os
    import statistics

    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    from .viewer import MODES, Renderer

    sim = Simulation(dam_break_scene(n_target))
    sim.run(0.3)  # a broken column: a realistic picture
    pygame.display.init()
    pygame.font.init()
    try:
        surface = pygame.Surface(size)
        out = {}
        for mode in MODES:
            r = Renderer(sim, size, mode)
            r.draw(surface)  # warm up: first-use allocations are not per frame
            times = []
            for _ in range(frames):
                start = time.perf_counter()
                r.draw(surface)
                times.append(1000 * (time.perf_counter() - start))
            out[mode] = statistics.median(times)
    finally:
        pygame.quit()
    return {"particles": sim.n_particles, "size": size, "ms": out}


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    cpu = line.split(":", 1)[1].strip()
                    break
    except OSError:
        pass
    return f"{cpu}, {os.cpu_count()} cores, {platform.system()} {platform.release()}"


def bench_scene(n_target: int, method: str = "seed", surface_tension: float = 0.0,
                pair_precision: str = "double") -> dict:
    """dam_break_scene, with the given surface tension (N/m) when it is not 0 and
    the given precision of the seed's pair sums."""
    scene = dam_break_scene(n_target, method)
    if surface_tension:
        scene["fluid"]["surface_tension"] = surface_tension
    if pair_precision != "double":
        scene["solver"]["pair_precision"] = pair_precision
    return scene


def run_case(n_target: int, threads: int, steps: int, warmup: int, method: str = "seed",
             surface_tension: float = 0.0, pair_precision: str = "double") -> dict:
    sim = Simulation(bench_scene(n_target, method, surface_tension, pair_precision),
                     threads=threads)
    sim.step(warmup)
    sim._solver.reset_phase_seconds()
    n = sim.n_particles
    start = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - start
    phases = sim._solver.phase_seconds()
    t_star, z, z_ref = front_error(sim)
    return {"threads": threads, "in_use": sim.threads_in_use, "particles": n, "steps": steps,
            # the precision asked for, and the one that ran (float needs the cell clusters)
            "pairs": pair_precision,
            "pairs_ran": "float" if sim._solver.float_pairs else "double",
            # the double pair forces' 1/r: Newton steps (Intel CPUs) or root and division
            "recip_root": sim._solver.recip_root,
            "wall": wall,
            "steps_per_s": steps / wall, "pps": steps * n / wall,
            "ns_per_ps": 1e9 * wall / (steps * n),
            "phases_us": {k: 1e6 * v / steps for k, v in phases.items()},
            "T": t_star, "Z": z, "Z_ref": z_ref,
            "max_compression": sim.stats()["max_compression"]}


def median_run(runs: list[dict]) -> dict:
    """The run with the median wall time, annotated with the spread of all runs."""
    ordered = sorted(runs, key=lambda r: r["wall"])
    r = dict(ordered[len(ordered) // 2])
    r["range"] = (ordered[-1]["steps_per_s"], ordered[0]["steps_per_s"])
    r["repeats"] = len(runs)
    return r


def table(rows: list[dict], command: str) -> str:
    info = _core.build_info
    lines = [
        (f"Machine: {machine()}. Build: {info['compiler']}, {info['build_type']}, "
         f"{target()}, OpenMP "
         f"{info['openmp']}, {info['real']}. Date: {datetime.date.today().isoformat()}. "
         "The seed's double pair forces take 1/r from "
         + ("rsqrt14 and two Newton steps" if rows[0].get("recip_root")
            else "a square root and a division") + " on this CPU (Solver.recip_root)."),
        f"Command: `{command}`",
        "",
        (f"Each figure is the median of {rows[0]['repeats']} interleaved run(s); the range is "
         "the slowest and fastest run."),
        "",
        ("| threads | pairs | particles | steps | wall s | steps/s | range | particle-steps/s "
         "| ns/particle-step | speed-up | front Z (M&M) at T | max compression |"),
        "|---:|---|---:|---:|---:|---:|---|---:|---:|---:|---|---:|",
    ]
    base = rows[0]["wall"]
    for r in rows:
        lines.append(
            f"| {thread_label(r)} | {pairs_label(r)} | {r['particles']:,} | {r['steps']:,} | "
            f"{r['wall']:.3f} | "
            f"{r['steps_per_s']:,.0f} | {r['range'][0]:,.0f}–{r['range'][1]:,.0f} | "
            f"{r['pps'] / 1e6:.2f} M | {r['ns_per_ps']:.1f} | "
            f"{base / r['wall']:.2f} | {r['Z']:.2f} ({r['Z_ref']:.2f}) at {r['T']:.2f} | "
            f"{r['max_compression']:.3f} |")
    lines += ["", "Time per step by phase (microseconds):", "",
              "| threads | pairs | " + " | ".join(rows[0]["phases_us"]) + " |",
              "|---:|---|" + "---:|" * len(rows[0]["phases_us"])]
    for r in rows:
        phases = " | ".join(f"{v:.0f}" for v in r["phases_us"].values())
        lines.append(f"| {thread_label(r)} | {pairs_label(r)} | {phases} |")
    lines += ["", "Speed-up: against the first row. Pairs: the precision of the seed's pair "
              "forces (`solver.pair_precision`; docs/method-seed.md, \"Pair forces in single precision\"). Phases: where the "
              "seed's pairs run by cell clusters with walls, the ghosts column holds the walls' "
              "share of the density and the equation of state too (found in one parallel "
              "region), and density is empty."]
    if any(thread_label(r) != str(r["threads"]) for r in rows):
        lines += ["", "\"(1 in use)\": below 1,000 particles the step runs on one thread "
                  "whatever is asked (`Simulation.threads_in_use`)."]
    return "\n".join(lines) + "\n"


def pairs_label(r: dict) -> str:
    """The precision of the pair forces, and what ran where that differs."""
    ran = r.get("pairs_ran", "double")
    asked = r.get("pairs", "double")
    return ran if ran == asked else f"{asked} ({ran} ran)"


def thread_label(r: dict) -> str:
    """The threads asked for, and those in use where fewer (small scenes)."""
    if r.get("in_use", r["threads"]) == r["threads"]:
        return str(r["threads"])
    return f"{r['threads']} ({r['in_use']} in use)"


def write_section(path: Path, text: str, tag: str = "bench") -> None:
    """Replace the generated section `tag` of a Markdown file (or append one)."""
    begin, end = f"<!-- sphfluid {tag}: begin -->", f"<!-- sphfluid {tag}: end -->"
    block = f"{begin}\n{text}{end}\n"
    old = path.read_text() if path.exists() else ""
    if begin in old and end in old:
        new = old[:old.index(begin)] + block + old[old.index(end) + len(end) + 1:]
    else:
        new = old + ("\n" if old and not old.endswith("\n") else "") + block
    path.write_text(new)


# --- the command: parsing, running, tabulating, writing -------------------------------


@dataclass(frozen=True)
class Plan:
    """What `sphfluid bench` times: the cases (pair precision, threads), each run
    `repeat` times in rounds."""

    particles: int
    steps: int
    warmup: int
    repeat: int
    method: str
    threads: tuple[int, ...]
    precisions: tuple[str, ...]
    surface_tension: float  # N/m

    @property
    def cases(self) -> list[tuple[str, int]]:
        return [(p, t) for p in self.precisions for t in self.threads]


def parse_plan(args) -> Plan:
    """The options of the timing run, checked; ValueError with the message to print."""
    try:
        threads = [int(t) for t in str(args.threads).split(",")]
        if not threads or min(threads) < 1:
            raise ValueError
    except ValueError:
        raise ValueError(f"--threads: expected a list like 1,2, got {args.threads!r}") from None
    if args.particles < 100 or args.steps < 1:
        raise ValueError("--particles must be >= 100 and --steps >= 1")
    if args.repeat < 1:
        raise ValueError("--repeat must be >= 1")
    sigma = args.surface_tension
    if not (math.isfinite(sigma) and sigma >= 0):
        raise ValueError(f"--surface-tension must be a finite number >= 0, got {sigma}")
    precisions = str(args.pair_precision).split(",")
    if not precisions or any(p not in ("double", "float") for p in precisions):
        raise ValueError(f"--pair-precision: expected double, float or double,float, got "
                         f"{args.pair_precision!r}")
    if "float" in precisions and args.method != "seed":
        raise ValueError("--pair-precision float applies to the seed method only")
    return Plan(args.particles, args.steps, args.warmup, args.repeat, args.method,
                tuple(threads), tuple(precisions), sigma)


def command_line(plan: Plan, args) -> str:
    """The command that reproduces the table, as its header quotes it."""
    return "sphfluid bench " + " ".join(
        f"--{k} {v}" for k, v in (("particles", plan.particles), ("steps", plan.steps),
                                  ("warmup", plan.warmup), ("threads", args.threads),
                                  ("repeat", plan.repeat), ("method", plan.method))) + (
        f" --pair-precision {args.pair_precision}" if plan.precisions != ("double",) else "") + (
        f" --surface-tension {plan.surface_tension:g}" if plan.surface_tension else "")


def _log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def run_plan(plan: Plan, reference=None, log=_log) -> tuple[dict, dict]:
    """Our runs of every case, and the reference loop's on every thread count when
    given, in rounds: one run of each per round, so that slow spells of a shared
    machine hit all of them. Returns ({case: runs}, {threads: reference steps/s})."""
    runs: dict[tuple[str, int], list[dict]] = {c: [] for c in plan.cases}
    ref_runs: dict[int, list[float]] = {t: [] for t in plan.threads} if reference else {}
    for _ in range(plan.repeat):
        for p, t in plan.cases:
            r = run_case(plan.particles, t, plan.steps, plan.warmup, plan.method,
                         plan.surface_tension, p)
            runs[(p, t)].append(r)
            log(f"{t} thread(s), {p} pairs: {r['particles']:,} particles, "
                f"{r['steps_per_s']:,.0f} "
                f"steps/s, {r['pps'] / 1e6:.2f} M particle-steps/s, {r['ns_per_ps']:.1f} "
                f"ns/particle-step; front Z = {r['Z']:.2f} at T = {r['T']:.2f} "
                f"(Martin & Moyce {r['Z_ref']:.2f})")
        try:
            for t in ref_runs:
                ref_runs[t].append(reference.run(t))
                log(f"{t} thread(s), reference loop: {ref_runs[t][-1]:,.0f} steps/s")
        except RuntimeError as e:
            log(f"note: the reference loop failed ({e}); the table goes on without it")
            ref_runs.clear()
    return runs, ref_runs


def main(args) -> int:
    if args.draw:
        return print_draw_times(args.particles)
    if args.guard_cost:
        return print_guard_cost(args.particles, args.steps, args.repeat)
    try:
        plan = parse_plan(args)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="sphfluid-bench-reference-") as folder:
        reference = ReferenceRuns.prepare(plan, Path(folder), args.benchmarks_dir)
        runs, ref_runs = run_plan(plan, reference)
    text = table([median_run(runs[c]) for c in plan.cases], command_line(plan, args))
    if ref_runs:
        text += "\n" + reference_lines(plan, runs, ref_runs, reference.note)
    print(text)
    if args.write:
        write_section(args.write, text)
        print(f"wrote {args.write}", file=sys.stderr)
    return 0


def print_draw_times(particles: int) -> int:
    d = draw_times(particles, 30)
    budget = 1000 / 60 / 4
    print(f"drawing the dam break, {d['particles']:,} particles, {d['size'][0]}x"
          f"{d['size'][1]} pixels, median of 30 frames (budget at 60 fps: a quarter "
          f"frame = {budget:.1f} ms):")
    for mode, ms in d["ms"].items():
        print(f"  {mode:9s} {ms:6.2f} ms  {'within' if ms <= budget else 'OVER'} budget")
    return 0


def print_guard_cost(particles: int, steps: int, repeat: int) -> int:
    g = guard_cost(particles, steps, repeat)
    print(f"dam break, {particles:,} particles, 1 thread, median of {repeat} "
          f"interleaved runs of {steps} steps:\n"
          f"  step {1e6 * g['step_on']:.0f} us with the guard, {1e6 * g['step_off']:.0f} us "
          f"without\n  integrate phase {1e6 * g['integrate_on']:.1f} us with, "
          f"{1e6 * g['integrate_off']:.1f} us without\n"
          f"  guard cost {100 * g['cost_fraction']:.2f} % of a step")
    return 0


# --- the reference loop: benchmarks/reference_loop.cpp --------------------------------


class ReferenceRuns:
    """The plain reference loop (benchmarks/reference_loop.cpp), built once, run on
    the plan's dam break: the seed's particles, physics, dt and steps, its walls by
    reflection (benchmarks/reference_loop.py builds and runs it)."""

    def __init__(self, loop: ModuleType, binary: Path, inputs: dict[int, Path], note: str):
        self.loop, self.binary, self.inputs, self.note = loop, binary, inputs, note

    @classmethod
    def prepare(cls, plan: Plan, folder: Path, explicit: Path | None = None, log=_log):
        """Build the loop and write its inputs into `folder`, one per thread count;
        None, after a one-line note, when benchmarks/ or a compiler is missing."""
        try:
            loop = load_benchmark(benchmarks_dir(explicit), "reference_loop.py")
            binary = loop.build()
        except (BenchmarksNotFoundError, RuntimeError) as e:
            log(f"note: no reference loop ({e}); the table goes on without it")
            return None
        inputs = {t: reference_input(loop, folder / f"threads_{t}.txt", plan, t)
                  for t in plan.threads}
        note = f"`{loop.compiler()} {' '.join(loop.FLAGS)}`"
        return cls(loop, binary, inputs, note)

    def run(self, threads: int) -> float:
        return self.loop.run(self.binary, self.inputs[threads])


def reference_input(loop: ModuleType, path: Path, plan: Plan, threads: int) -> Path:
    """The reference loop's input: the seed's dam break at plan.particles (its
    lattice, mass, h, k, rho0, eta, g and dt), plan.warmup + plan.steps steps."""
    from .scene import load_scene

    scene = load_scene(dam_break_scene(plan.particles, "seed"))
    positions, velocities = scene.lattice_points()
    mass = (scene.particle_mass if scene.particle_mass is not None
            else _core.kernels.lattice_mass(scene.rest_density, scene.spacing,
                                            scene.smoothing_length))
    return loop.write_input(path, positions, velocities, mass=mass,
                            h=scene.smoothing_length, k=scene.gas_constant,
                            rho0=scene.rest_density, eta=scene.viscosity,
                            gx=scene.gravity[0], gy=scene.gravity[1], tank=GEOMETRY.tank,
                            dt=scene.time_step, warmup=plan.warmup, steps=plan.steps,
                            threads=threads)


def reference_lines(plan: Plan, runs: dict, ref_runs: dict, compiled: str) -> str:
    """Our speed as a multiple of the reference loop's, per thread count: the median
    over the rounds of each round's ratio, so that the machine's speed cancels."""
    lines = [
        ("Reference loop (`benchmarks/reference_loop.cpp`, built with " + compiled + "): "
         "the seed's density, pressure and viscosity forces and semi-implicit Euler over a "
         "cell list rebuilt every step, scalar C++17 with one OpenMP loop per pass, the "
         "walls by reflection instead of ghosts; on the same particles, dt and steps, run "
         "in each round after ours. Ours ÷ reference: the median over the rounds of each "
         "round's ratio of steps/s."),
        "",
    ]
    for t, ref in ref_runs.items():
        ratios = ", ".join(
            f"{pairs_label(median_run(runs[(p, t)]))} "
            f"{statistics.median(r['steps_per_s'] / f for r, f in zip(runs[(p, t)], ref)):.2f}"
            for p in plan.precisions)
        lines.append(f"- {t} thread{'s' if t > 1 else ''}: reference "
                     f"{statistics.median(ref):,.0f} steps/s ({min(ref):,.0f}–{max(ref):,.0f}); "
                     f"ours ÷ reference: {ratios}")
    return "\n".join(lines) + "\n"
