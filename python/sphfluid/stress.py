"""`sphfluid stress`: a stability matrix and a set of violent scenes.

For the seed method with a fixed dt, a sweep of the gas constant k against dt on
the dam break and the splash: each run either stays stable for its whole
duration, is caught by the guard (InstabilityError, with the check that
tripped), or goes bad silently (particles lost from the domain or outside the
tank although the guard never tripped: the number that must stay zero). The
same sweep with the adaptive step, then violent scenes with the adaptive step.
Writes a table (STABILITY.md) and heat maps (PNG, when matplotlib is present).
"""
from __future__ import annotations

import copy
import datetime
import os
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from . import engine
from .bench import machine
from .metadata import source_line
from .scene import METHODS, load_scene
from .simulation import InstabilityError, Simulation

STABLE, CAUGHT, SILENT = "stable", "caught", "silent"


@dataclass
class Outcome:
    status: str  # stable | caught | silent
    detail: str  # the check that tripped, or what went wrong
    steps: int
    sim_time: float
    wall: float
    lost: int  # particles removed from the domain or outside the container
    through_walls: int = 0  # of those, the ones that must have crossed a wall


def check_name(error: InstabilityError) -> str:
    """The guard check named in an InstabilityError's message."""
    m = re.search(r"\[check: (\w+)\]", str(error))
    return m.group(1) if m else "guard"


def tank_scene(kind: str, spacing: float, duration: float) -> dict:
    """The dam break or the splash of scenes/, at a coarser spacing for sweeps.

    The tank is closed, 5 m high, like the violent scenes' box, so that a
    particle outside it went through a wall or blew out of the domain. With an
    open top, spray thrown ballistically over the walls counted as lost: the
    dam break's run-up jet rises to about 4 m at k >= 1000 (traced: 5.5 m/s
    upwards at y = 2.5 m), over the bundled scene's 3 m walls, and at k = 1000,
    dt = 1e-5 s three spray particles flew over 5 m walls at t = 1.74 s while
    the run's total energy fell (STABILITY.md).
    """
    walls = [{"polyline": [[0.0, 5.0], [0.0, 0.0], [4.0, 0.0], [4.0, 5.0]], "closed": True}]
    if kind == "dam_break":
        regions = [{"shape": "rectangle", "min": [0.0, 0.0], "max": [1.0, 2.0]}]
    else:
        regions = [{"shape": "rectangle", "min": [0.0, 0.0], "max": [4.0, 0.6]},
                   {"shape": "circle", "center": [2.0, 1.6], "radius": 0.35,
                    "velocity": [0.0, -2.0]}]
    return {
        "format": "sphfluid-scene/1", "name": f"stress {kind}",
        "domain": {"min": [-0.1, -0.1], "max": [4.1, 5.6]},
        "fluid": {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0},
        "resolution": {"spacing": spacing},
        "fluid_regions": regions, "walls": walls,
        "solver": {"method": "seed", "time_step": 1e-4}, "duration": duration,
    }


def container(scene: dict) -> tuple[np.ndarray, np.ndarray, bool] | None:
    """Bounding box of the walls (the scene's container) and whether it has a lid."""
    pts, closed = [], False
    for w in scene.get("walls", []):
        pts += w["polyline"] if isinstance(w, dict) else w
        closed = closed or (isinstance(w, dict) and w.get("closed", False))
    if not pts:
        return None
    p = np.asarray(pts, float)
    return p.min(axis=0), p.max(axis=0), closed


def run_one(scene: dict, max_wall: float, threads: int | None = None) -> Outcome:
    sim = Simulation(load_scene(scene), threads=threads)
    box = container(scene)
    start = time.perf_counter()
    status, detail = STABLE, ""
    end = scene["duration"]
    try:
        while sim.time < end * (1 - 1e-12):
            sim.advance_to(min(end, sim.time + end / 50))
            if time.perf_counter() - start > max_wall:
                detail = f"stopped at t = {sim.time:.3g} s (over {max_wall:g} s of wall time)"
                break
    except InstabilityError as e:
        status, detail = CAUGHT, check_name(e)
    wall = time.perf_counter() - start
    lost = sim.removed_particles
    # In a closed container the domain's edge is beyond the walls: leaving it
    # means crossing one. Over an open top it need not.
    through_walls = lost if box is not None and box[2] else 0
    if box is not None and sim.n_particles:
        lo, hi, closed = box
        x = sim.positions
        # Below the floor or beyond a side wall, under the top of the walls (or
        # anywhere outside a closed container).
        outside = ((x[:, 1] < lo[1]) | (((x[:, 0] < lo[0]) | (x[:, 0] > hi[0]))
                                        & (x[:, 1] < hi[1])))
        if closed:
            outside |= x[:, 1] > hi[1]
        lost += int(outside.sum())
        through_walls += int(outside.sum())
    if status == STABLE and lost:
        status, detail = SILENT, f"{lost} particles lost"
    elif status == CAUGHT and lost:
        detail += f"; {lost} particles had left first"
    return Outcome(status, detail, sim.step_count, sim.time, wall, lost, through_walls)


def with_precision(d: dict, precision: str) -> dict:
    """The scene with the seed's pair forces in `precision` (wcsph: as it is)."""
    if precision != "double" and d["solver"].get("method", "seed") == "seed":
        d["solver"]["pair_precision"] = precision
    return d


@dataclass(frozen=True, eq=False)
class Job:
    """One run of the report: which table it belongs to, its cell there, its scene."""

    part: str  # "dam_break" | "splash" (the sweeps), "violent" or "bundled"
    cell: tuple  # (k, dt) in a sweep, (method, scene name) or (file, how)
    scene: dict
    max_wall: float
    label: str  # the start of its log line


def sweep_jobs(kind: str, p: Plan, precision: str) -> list[Job]:
    """The k x dt sweep of one tank, fixed dts first, then the adaptive step."""
    jobs = []
    for dt in [*p.dts, None]:
        for k in p.ks:
            d = tank_scene(kind, p.spacing, p.duration)
            d["fluid"]["gas_constant"] = k
            d["solver"]["time_step"] = "auto" if dt is None else dt
            jobs.append(Job(kind, (k, dt), with_precision(d, precision), p.max_wall,
                            f"{kind:9s} k = {k:8.3g}  dt = "
                            f"{'auto' if dt is None else f'{dt:.0e}':>6s} "))
    return jobs


def violent_jobs(p: Plan, precision: str) -> list[Job]:
    """Each violent scene with each method (four times the sweeps' wall-time cap)."""
    jobs = []
    for method in METHODS:
        for name, d in violent_scenes(p.tank_steps).items():
            d["solver"]["method"] = method
            jobs.append(Job("violent", (method, name), with_precision(d, precision),
                            p.max_wall * 4, f"{method:5s} {name:40s}"))
    return jobs


def bundled_jobs(folder: Path, max_wall: float, precision: str) -> list[Job]:
    """Each scene of folder as shipped and with each method."""
    return [Job("bundled", (name, how), with_precision(d, precision), max_wall,
                f"{name:18s} {how:32s}")
            for (name, how), d in bundled_scenes(folder).items()]


def run_job(task: tuple[Job, int | None]) -> Outcome:
    """One job on `threads` OpenMP threads (a task of engine.execute)."""
    job, threads = task
    scene = copy.deepcopy(job.scene)
    if job.part == "violent":  # (a tank at rest runs a number of steps)
        return run_violent(scene, job.max_wall, threads)
    return run_one(scene, job.max_wall, threads)


def violent_scenes(tank_steps: int) -> dict[str, dict]:
    """Scenes meant to break a solver, all with the adaptive step."""
    base = {"format": "sphfluid-scene/1", "domain": {"min": [-0.2, -0.2], "max": [2.2, 2.2]},
            "fluid": {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0},
            "resolution": {"spacing": 0.02}, "walls": [],
            "solver": {"method": "seed", "time_step": "auto"}, "duration": 1.0}
    # A closed box: whatever leaves it went through a wall or out of the domain.
    box = {"polyline": [[0.0, 2.0], [0.0, 0.0], [2.0, 0.0], [2.0, 2.0]], "closed": True}
    out = {}

    d = copy.deepcopy(base)  # a fast jet hitting a wall
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.1, 0.8], "max": [0.5, 1.0],
                           "velocity": [20.0, 0.0]}]
    d["walls"] = [box]
    out["jet at 20 m/s into a wall"] = d

    d = copy.deepcopy(base)  # fluid dropped into a narrow wedge
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.8, 1.2], "max": [1.2, 1.8]}]
    d["walls"] = [{"polyline": [[0.5, 1.9], [1.0, 0.05], [1.5, 1.9]]}, box]
    out["drop into a narrow wedge"] = d

    d = copy.deepcopy(base)  # overlapping regions and particles exactly on a wall
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.01, 0.01], "max": [0.61, 0.61]},
                          {"shape": "rectangle", "min": [0.3, 0.3], "max": [0.9, 0.9]}]
    d["walls"] = [box, [[0.0, 0.31], [1.0, 0.31]]]  # a wall through lattice points
    out["particles overlapping and on a wall"] = d

    d = copy.deepcopy(base)  # a very viscous blob
    d["fluid"]["viscosity"] = 5000.0
    d["fluid_regions"] = [{"shape": "circle", "center": [1.0, 1.0], "radius": 0.3,
                           "velocity": [0.0, -3.0]}]
    d["walls"] = [box]
    out["very viscous blob (5000 Pa s)"] = d

    d = copy.deepcopy(base)  # strong surface tension, no gravity
    d["gravity"] = [0.0, 0.0]
    d["fluid"].update(gas_constant=50.0, viscosity=5.0, surface_tension=200.0)
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.7, 0.7], "max": [1.3, 1.3]}]
    out["strong surface tension (200 N)"] = d

    d = copy.deepcopy(base)  # a thin-walled container: two walls 1 mm apart
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.05, 0.05], "max": [0.95, 1.5]}]
    d["walls"] = [box, [[1.0, 0.0], [1.0, 1.9]], [[1.001, 0.0], [1.001, 1.9]]]
    out["thin-walled container (1 mm)"] = d

    d = copy.deepcopy(base)  # a tank at rest for many steps
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.0, 0.0], "max": [1.0, 0.5]}]
    d["walls"] = [{"polyline": [[0.0, 1.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]}]
    d["resolution"] = {"spacing": 0.025}
    d["fluid"]["viscosity"] = 100.0
    d["duration"] = None
    d["tank_steps"] = tank_steps
    out[f"tank at rest, {tank_steps:,} steps"] = d
    return out


def run_violent(d: dict, max_wall: float, threads: int | None = None) -> Outcome:
    steps = d.pop("tank_steps", None)
    if steps is None:
        return run_one(d, max_wall, threads)
    d["duration"] = 1.0
    sim = Simulation(load_scene(d), threads=threads)
    start = time.perf_counter()
    status, detail = STABLE, ""
    try:
        done = 0
        while done < steps:
            n = min(10_000, steps - done)
            sim.step(n)
            done += n
            if time.perf_counter() - start > max_wall:
                detail = f"stopped after {done:,} steps (wall time)"
                break
    except InstabilityError as e:
        status, detail = CAUGHT, check_name(e)
    x = sim.positions
    outside = int(((x < 0.0) | (x > 1.0)).any(axis=1).sum()) + sim.removed_particles
    if status == STABLE and outside:
        status, detail = SILENT, f"{outside} particles lost"
    if status == STABLE:
        detail = detail or f"max speed {sim.stats()['max_speed']:.3f} m/s at t = {sim.time:.0f} s"
    return Outcome(status, detail, sim.step_count, sim.time, time.perf_counter() - start,
                   outside, outside)


def bundled_scenes(folder: Path) -> dict[tuple[str, str], dict]:
    """Each scene of `folder` as shipped, then with each method and the adaptive
    step: the format promises that changing `solver.method` alone runs a scene,
    within what the method takes (a scene a method refuses, with the reason, is
    left out)."""
    import json

    from .scene import SceneError, load_scene

    out = {}
    for path in sorted(folder.glob("*.json")):
        shipped = json.loads(path.read_text())
        solver = shipped.setdefault("solver", {})
        how = (f"{solver.get('method', 'seed')}, dt as shipped "
               f"({solver.get('time_step', 'default')})")
        out[(path.name, how)] = shipped
        for method in METHODS:
            d = copy.deepcopy(shipped)
            d["solver"].update(method=method, time_step="auto")
            try:
                load_scene(d)
            except SceneError:
                continue
            out[(path.name, f"{method}, auto")] = d
    return out


def heat_map(results: dict, ks: list[float], dts: list, title: str, path: Path) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        from matplotlib.colors import ListedColormap
    except ImportError:
        return False
    code = {STABLE: 0, CAUGHT: 1, SILENT: 2}
    grid = np.array([[code[results[(k, dt)].status] for k in ks] for dt in dts])
    fig, ax = plt.subplots(figsize=(max(6.0, 1.5 + 0.8 * len(ks)), 1.6 + 0.55 * len(dts)))
    ax.imshow(grid, cmap=ListedColormap(["#3a9a5b", "#e0a030", "#c0392b"]), vmin=0, vmax=2,
              aspect="auto", origin="lower")
    for r, dt in enumerate(dts):
        for c, k in enumerate(ks):
            o = results[(k, dt)]
            label = "ok" if o.status == STABLE else (o.detail if o.status == CAUGHT else "SILENT")
            ax.text(c, r, label, ha="center", va="center", fontsize=7)
    ax.set_xticks(range(len(ks)), [f"{k:.0e}" for k in ks], fontsize=8)
    ax.set_yticks(range(len(dts)), ["auto" if dt is None else f"{dt:.0e}" for dt in dts],
                  fontsize=8)
    ax.set_xlabel("gas constant k (m²/s²)")
    ax.set_ylabel("time step dt (s)")
    ax.set_title(title + "\ngreen: stable, orange: caught by the guard (check named), "
                 "red: silent failure", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return True


@dataclass(frozen=True)
class Plan:
    """What a stress run sweeps and for how long: --quick or --full."""

    ks: list[float]  # gas constants, m^2/s^2
    dts: list[float]  # fixed time steps, s (each sweep also runs the adaptive step)
    spacing: float  # m
    duration: float  # simulated s per sweep run
    max_wall: float  # wall-time cap per run, s (violent scenes: 4 x)
    tank_steps: int  # steps of the tank at rest


def plan(full: bool) -> Plan:
    if full:
        return Plan(ks=[10.0**e for e in range(8)], dts=[1e-5, 1e-4, 1e-3, 1e-2], spacing=0.04,
                    duration=2.0, max_wall=600.0, tank_steps=1_000_000)
    return Plan(ks=[1.0, 1e2, 1e4, 1e6], dts=[1e-4, 1e-3, 1e-2], spacing=0.08, duration=0.5,
                max_wall=30.0, tank_steps=20_000)


@dataclass
class Tally:
    """The outcomes of every run of a report, counted."""

    status: dict[str, int] = field(default_factory=lambda: {STABLE: 0, CAUGHT: 0, SILENT: 0})
    runs: int = 0
    lost: int = 0  # particles gone in runs the guard let finish (the silent failures' count)
    walls: int = 0  # particles that crossed a wall, in any run

    def add(self, outcomes) -> None:
        for o in outcomes:
            self.runs += 1
            self.status[o.status] += 1
            self.lost += o.lost if o.status != CAUGHT else 0
            self.walls += o.through_walls


def log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def run_jobs(jobs: list[Job], args) -> list[Outcome]:
    """Every job, through the engine: one after another in this process by
    default (--workers 0), else on Dask; each finished run's line as it comes."""
    from .progress import Runs

    workers, scheduler = args.workers, args.scheduler
    threads = engine.threads_per_run(args.threads, workers, scheduler)
    if not engine.in_process(workers, scheduler):
        log(f"{len(jobs)} runs {engine.where(workers, threads, scheduler)}, "
            f"{threads} thread(s) each")
    outcomes: list[Outcome | None] = [None] * len(jobs)
    with Runs(len(jobs)) as runs:
        def done(place: int, o: Outcome) -> None:
            job = jobs[place]
            outcomes[place] = o
            runs.done(f"{job.label} {o.status:6s} {o.detail}  {o.steps:,} steps  "
                      f"{o.wall:.1f} s")

        engine.execute(run_job, [(j, threads) for j in jobs], done, workers=workers,
                       threads=threads or 1, scheduler=scheduler,
                       name=lambda place: f"stress-{jobs[place].part}")
    return outcomes  # type: ignore[return-value] (every place filled)


def main(args) -> int:
    """`sphfluid stress`: the sweeps, the violent scenes (and with --full the bundled
    scenes), a Markdown report; 1 when any run failed silently."""
    full = args.full
    p = plan(full)
    precision = getattr(args, "pair_precision", "double")
    if full and not args.scenes.is_dir():
        if args.write:
            # Checked before the run: the report would replace the section
            # without its bundled-scenes table, after tens of minutes.
            log(f"error: no scene folder {args.scenes}: --full --write needs the bundled "
                "scenes (run from the repository, or pass --scenes DIR)")
            return 2
        log(f"no scene folder {args.scenes}: the bundled scenes will be skipped "
            "(--scenes DIR to run them)")
    engine.check(args.workers, args.scheduler)
    args.out.mkdir(parents=True, exist_ok=True)

    start = time.perf_counter()
    kinds = ("dam_break", "splash")
    jobs = [j for kind in kinds for j in sweep_jobs(kind, p, precision)]
    jobs += violent_jobs(p, precision)
    if full and args.scenes.is_dir():
        jobs += bundled_jobs(args.scenes, p.max_wall, precision)
    outcomes = run_jobs(jobs, args)
    tally = Tally()
    tally.add(outcomes)
    part: dict[str, dict] = {name: {} for name in (*kinds, "violent", "bundled")}
    for job, o in zip(jobs, outcomes):
        part[job.part][job.cell] = o
    sections = [sweep_section(kind, p, precision, args, part[kind]) for kind in kinds]
    violent = part["violent"]
    bundled = part["bundled"] if full and args.scenes.is_dir() else None  # (None: not run)
    report = report_text(args, p, precision, time.perf_counter() - start, tally, sections,
                         violent, bundled)
    print(report)
    if args.write:
        from .bench import write_section

        write_section(args.write, report, tag="stress" + ("" if precision == "double"
                                                          else f" {precision}"))
        log(f"wrote {args.write}")
    return 1 if tally.status[SILENT] else 0


def sweep_section(kind: str, p: Plan, precision: str, args, results: dict) -> str:
    """One tank's k x dt table (fixed dts, then the adaptive step) and heat map."""
    png = args.out / f"stability_{kind}{'' if precision == 'double' else f'_{precision}'}.png"
    drew = heat_map(results, p.ks, p.dts + [None],
                    f"seed method{'' if precision == 'double' else ', float pair forces'}, "
                    f"{kind.replace('_', ' ')} (spacing {p.spacing} m, {p.duration} s)", png)
    rows = ["| dt \\ k | " + " | ".join(f"{k:.0e}" for k in p.ks) + " |",
            "|---|" + "---|" * len(p.ks)]
    for dt in p.dts + [None]:
        cells = [sweep_cell(results[(k, dt)]) for k in p.ks]
        rows.append(f"| {'auto' if dt is None else f'{dt:.0e}'} | " + " | ".join(cells) + " |")
    link = os.path.relpath(png, args.write.parent if args.write else Path("."))
    return (f"### {kind.replace('_', ' ').capitalize()}\n\n" + "\n".join(rows)
            + (f"\n\n![{kind}]({link})" if drew else "") + "\n")


def sweep_cell(o: Outcome) -> str:
    if o.status == STABLE:
        return "stable"
    return f"caught ({o.detail})" if o.status == CAUGHT else f"**SILENT** ({o.detail})"


def outcome_row(first: str, second: str, o: Outcome) -> str:
    return (f"| {first} | {second} | {o.status}{f' ({o.detail})' if o.detail else ''} | "
            f"{o.steps:,} | {o.sim_time:.3g} | {o.wall:.1f} |")


def report_text(args, p: Plan, precision: str, elapsed: float, tally: Tally,
                sections: list[str], violent: dict, bundled: dict | None) -> str:
    """The Markdown report: the totals, what was run, then a section per part."""
    vrows = ["| method | scene (adaptive dt) | outcome | steps | simulated s | wall s |",
             "|---|---|---|---:|---:|---:|"]
    vrows += [outcome_row(method, name, o) for (method, name), o in violent.items()]
    scene_rows = []
    if bundled is not None:
        scene_rows = ["### Bundled scenes", "",
                      (f"Each scene in `{args.scenes}` as shipped, then with each method "
                       "and `time_step: auto`."), "",
                      "| scene | method, step | outcome | steps | simulated s | wall s |",
                      "|---|---|---|---:|---:|---:|"]
        scene_rows += [outcome_row(name, how, o) for (name, how), o in bundled.items()] + [""]
    which = "" if precision == "double" else f" (pair forces in {precision})"
    command = ("sphfluid stress " + ("--full" if args.full else "--quick") + f" --out {args.out}"
               + ("" if precision == "double" else f" --pair-precision {precision}")
               + engine.options(args.workers, args.threads, args.scheduler))
    return "\n".join([
        (f"Machine: {machine()}. {source_line()}. Date: {datetime.date.today().isoformat()}. "
         f"Command: `{command}` ({elapsed:.0f} s)."),
        "",
        ("| runs | stable | caught by the guard | silent failures (goal 0) | particles lost "
         "in runs not caught (goal 0) | particles through walls, any run (goal 0) |"),
        "|---:|---:|---:|---:|---:|---:|",
        (f"| {tally.runs} | {tally.status[STABLE]} | {tally.status[CAUGHT]} | "
         f"{tally.status[SILENT]} | {tally.lost} | {tally.walls} |"),
        "",
        ("A particle is lost when it leaves the domain or ends outside the walls' bounding box "
         "(for an open box: below its top). It went through a wall when the box is closed "
         "(anything lost), or when it ends outside an open box below its top. Caught runs say "
         "how many particles had left before the trip."),
        "",
        (f"Sweeps: seed method{which}, fixed dt and adaptive (`auto`, cfl 0.4), spacing "
         f"{p.spacing} m, {p.duration} s simulated (a run stopped by its {p.max_wall:g} s "
         "wall-time cap counts as stable up to where it got, and says so in the log)."),
        "",
        *sections,
        "### Violent scenes",
        "",
        *vrows,
        "",
        *scene_rows,
    ])
