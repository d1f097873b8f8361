"""Parameter sweeps: many runs of one scene, as tasks on Dask distributed.

A sweep file (``sweep.schema.json``, docs/sweeps.md) names a base scene, the
keys to vary by JSON path (lists, ranges, random draws), how to combine them
(every combination, or side by side), the methods, and what each run keeps.
``load_sweep`` checks the file and every scene it makes before anything runs;
``run_sweep`` runs the missing ones (a LocalCluster of worker processes by
default, an existing scheduler by address, or a plain loop), and keeps one row
per run in ``DIR/results.csv``, rewritten whole after each run: its parameters,
its summary (the numbers ``sphfluid run`` prints), its status (ok, blow-up or
error, with the message), wall time and host. A run is known by a hash of its
scene, duration, outputs and the sphfluid version: a sweep run again skips the
runs whose row says ok or blow-up, and runs the rest.
"""
from __future__ import annotations

import csv
import hashlib
import io
import itertools
import json
import math
import os
import re
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from . import engine
from . import schema as _schema
from .scene import METHODS, SceneError

SCHEMA_FILE = "sweep.schema.json"
FORMAT = _schema.scene_schema(SCHEMA_FILE)["properties"]["format"]["const"]  # "sphfluid-sweep/1"
RESULTS = "results.csv"
MAX_RUNS = 100_000
DONE = ("ok", "blow-up")  # statuses a sweep run again keeps (an error runs again)
WRITE_EVERY = 2.0  # s: the table is rewritten after a run at most this often (and at the end)
_SUMMARY = ("steps", "simulated_time", "wall_time", "particles", "removed", "max_density_error",
            "max_compression", "max_speed", "retried_steps", "mean_dt", "particle_steps_per_s")
_PATH_TOKEN = re.compile(r"\.?([A-Za-z_][A-Za-z0-9_]*)|\[(\d+)\]")


class SweepError(SceneError):
    """A sweep file that cannot run: ``problems`` lists each mistake by JSON path."""


@dataclass(frozen=True)
class Run:
    """One run of a sweep: its place, the values it sets, its scene."""

    index: int
    params: dict[str, Any]  # JSON path (and "method") -> value
    scene: dict
    repeat: int = 0  # how many earlier runs of the sweep have the same scene


@dataclass
class Sweep:
    """A checked sweep file: ``runs`` holds every run, scenes checked."""

    name: str
    duration: float
    outputs: tuple[str, ...]
    every: float | None
    runs: list[Run] = field(default_factory=list)
    columns: tuple[str, ...] = ()  # the parameters' names, in the file's order
    dataset: dict | None = None  # the file's "dataset" (sphfluid dataset), as given

    def key(self, run: Run) -> str:
        """What a run is known by: a hash of its scene, the duration, the outputs,
        the frame interval, the sphfluid version, and its place among runs of the
        same scene (a repeat is a run of its own)."""
        from . import __version__

        text = json.dumps({"scene": run.scene, "duration": self.duration,
                           "outputs": sorted(self.outputs), "every": self.every,
                           "version": __version__, "repeat": run.repeat},
                          sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def folder(self, out: Path, run: Run) -> Path:
        """Where a run keeps its outputs: DIR/runs/KEY."""
        return Path(out).resolve() / "runs" / self.key(run)


def parse_path(text: str) -> list[str | int] | None:
    """"fluid_regions[0].max[1]" as ["fluid_regions", 0, "max", 1]; None if it is not
    such a path."""
    out: list[str | int] = []
    pos = 0
    while pos < len(text):
        m = _PATH_TOKEN.match(text, pos)
        if m is None or (m.group(0).startswith(".") and not out):
            return None
        if m.group(1) is not None and out and not m.group(0).startswith("."):
            return None  # two names without a dot between them
        out.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        pos = m.end()
    return out if out and isinstance(out[0], str) else None


def _set(scene: dict, path: list[str | int], value: Any) -> str | None:
    """Sets scene's value at path (a missing object on the way is made); the reason
    if the path leads nowhere in the scene, else None."""
    node: Any = scene
    for k, (step, nxt) in enumerate(zip(path, path[1:] + [None])):
        last = nxt is None
        here = _schema.json_path(path[:k + 1])
        if isinstance(step, int):
            if not isinstance(node, list) or step >= len(node):
                size = f"a list of {len(node)}" if isinstance(node, list) else _schema.kind(node)
                return f"the scene has no {here} ({_schema.json_path(path[:k]) or 'it'} is {size})"
        elif not isinstance(node, dict):
            return f"the scene has no {here} ({_schema.json_path(path[:k])} is {_schema.kind(node)})"
        if last:
            node[step] = value
            return None
        if isinstance(step, str) and step not in node:
            if isinstance(nxt, int):
                return f"the scene has no {here}"
            node[step] = {}  # (a misspelt key is the scene check's to name)
        node = node[step]
    return None


def _values(spec: Any, samples: int | None, rng) -> tuple[list, str | None]:
    """The values of one key: a list as given, a range, or random draws."""
    import numpy as np

    if isinstance(spec, list):
        return spec, None
    (kind, args), = spec.items()
    if kind == "uniform":
        if samples is None:
            return [], 'a random key needs "samples" (how many values to draw) at the top'
        low, high = args
        if not low < high:
            return [], f"uniform: expected low < high, got [{low:g}, {high:g}]"
        return [float(v) for v in rng.uniform(low, high, samples)], None
    first, last, count = args
    if kind == "logspace":
        if not (first > 0 and last > 0):
            return [], f"logspace: expected first and last > 0, got [{first:g}, {last:g}]"
        return [float(v) for v in np.geomspace(first, last, count)], None
    return [float(v) for v in np.linspace(first, last, count)], None


def _base_scene(data: dict, source: Path | None) -> tuple[dict | None, str | None]:
    scene = data["scene"]
    if isinstance(scene, dict):
        return json.loads(json.dumps(scene)), None
    path = Path(scene)
    if not path.is_absolute() and source is not None:
        path = source.parent / path
    try:
        scene = json.loads(path.read_text(encoding="utf-8"))
    except OSError as e:
        return None, f"cannot read {path}: {e.strerror or e}"
    except ValueError as e:
        return None, f"{path} is not JSON: {e}"
    if not isinstance(scene, dict):
        return None, f"{path} holds {_schema.kind(scene)}, not a scene (a JSON object)"
    return scene, None


def load_sweep(source: str | Path | dict) -> Sweep:
    """A sweep from a file or a dict, with every run it makes and every run's scene
    checked; a SweepError lists what is wrong, by JSON path."""
    data, path, name = _read(source)
    found = [f"{p}: {m}" if p else m for p, m in _schema.problems(data, SCHEMA_FILE)]
    if found:
        raise SweepError(found, name)
    base, why = _base_scene(data, path)
    if base is None:
        raise SweepError([f"scene: {why}"], name)
    axes, problems = _axes(data, base)
    problems += _method_problems(data.get("methods", []))
    duration, why = _duration(data, base)
    if why:
        problems.append(why)
    if problems:
        raise SweepError(problems, name)
    combos = _combinations(axes, data.get("combine", "grid"), name)
    methods = data.get("methods") or [None]
    count = len(combos) * len(methods)
    if count > MAX_RUNS:
        raise SweepError([f"vary: {count:,} runs; at most {MAX_RUNS:,} in one sweep"], name)
    outputs = tuple(dict.fromkeys(["summary", *data.get("outputs", [])]))
    sweep = Sweep(name=data.get("name", ""), duration=duration, outputs=outputs,
                  every=data.get("every"), dataset=data.get("dataset"),
                  columns=tuple(k for k, _, _ in axes) + (("method",) if data.get("methods") else ()))
    seen: dict[str, int] = {}
    for values in combos:
        for method in methods:
            scene = json.loads(json.dumps(base))
            params: dict[str, Any] = {}
            for (key, parsed, _), v in zip(axes, values):
                _set(scene, parsed, v)
                params[key] = v
            if method is not None:
                scene.setdefault("solver", {})["method"] = method
                params["method"] = method
            scene["duration"] = sweep.duration
            text = json.dumps(scene, sort_keys=True)
            sweep.runs.append(Run(len(sweep.runs), params, scene, seen.get(text, 0)))
            seen[text] = seen.get(text, 0) + 1
    problems = _scene_problems(sweep.runs)
    if problems:
        raise SweepError(problems, name)
    return sweep


def _read(source: str | Path | dict) -> tuple[Any, Path | None, str]:
    """The sweep file's JSON, its path (None for a dict) and its name for messages."""
    if isinstance(source, dict):
        return source, None, "sweep"
    path = Path(source)
    try:
        return json.loads(path.read_text(encoding="utf-8")), path, str(path)
    except OSError as e:
        raise SweepError([f"cannot read it: {e.strerror or e}"], str(path)) from None
    except ValueError as e:
        raise SweepError([f"not JSON: {e}"], str(path)) from None


def _axes(data: dict, base: dict) -> tuple[list[tuple[str, list[str | int], list]], list[str]]:
    """Each varied key: (key, its parsed path, its values); and the mistakes."""
    import numpy as np

    rng = np.random.default_rng(data.get("seed", 0))
    axes, problems = [], []
    for key, spec in data.get("vary", {}).items():
        parsed = parse_path(key)
        values, why = (_values(spec, data.get("samples"), rng) if parsed is not None
                       else ([], 'expected a JSON path into the scene such as "solver.cfl" or '
                                 '"fluid_regions[0].max[1]"'))
        if parsed is not None and parsed[0] == "duration":
            why = 'the runs\' duration is the sweep\'s "duration", not a key to vary'
        if not why:
            why = _set(json.loads(json.dumps(base)), parsed, values[0])
        if why:
            problems.append(f"{_schema.json_path(['vary', key])}: {why}")
        else:
            axes.append((key, parsed, values))
    return axes, problems


def _method_problems(methods: list) -> list[str]:
    return [f"methods[{k}]: expected {_schema.one_of(METHODS)}, got "
            f"{_schema.shown(m)}{_schema.did_you_mean(m, METHODS)}"
            for k, m in enumerate(methods) if m not in METHODS]


def _duration(data: dict, base: dict) -> tuple[float, str | None]:
    """The runs' duration: the sweep's, else the scene's; or why there is none."""
    if "duration" not in data and "duration" not in base:
        return 0.0, "duration: the scene gives no duration: give the runs' duration here"
    duration = data.get("duration", base.get("duration"))
    if not isinstance(duration, (int, float)) or isinstance(duration, bool) or not duration > 0:
        return 0.0, (f"scene.duration: expected a number > 0, got {_schema.shown(duration)} "
                     "(or give the runs' duration here)")
    return float(duration), None


def _scene_problems(runs: list[Run], most: int = 20) -> list[str]:
    """Each run's scene checked as the loader checks it; a mistake that several
    runs share (one of the base scene's) is told once; the first `most`."""
    from .scene import load_scene

    problems: list[str] = []
    told: set[str] = set()
    for run in runs:
        try:
            load_scene(run.scene)
        except SceneError as e:
            for p in e.problems:
                if p not in told:
                    told.add(p)
                    problems.append(f"run {run.index} ({_shown_params(run.params)}): {p}")
        if len(problems) >= most:
            problems.append(f"... (the first {most} problems)")
            break
    return problems


def _combinations(axes, combine: str, name: str) -> list[tuple]:
    lists = [values for _, _, values in axes]
    if not lists:
        return [()]
    if combine == "zip":
        lengths = {len(v) for v in lists}
        if len(lengths) > 1:
            sizes = ", ".join(f"{_schema.json_path(['vary', k])}: {len(v)}" for k, _, v in axes)
            raise SweepError([f'combine: "zip" needs lists of one length, got {sizes}'], name)
        return list(zip(*lists))
    count = math.prod(len(v) for v in lists)
    if count > MAX_RUNS:
        raise SweepError([f"vary: {count:,} combinations; at most {MAX_RUNS:,} in one sweep"], name)
    return list(itertools.product(*lists))


def _shown_params(params: dict) -> str:
    return ", ".join(f"{k} = {_schema.shown(v)}" for k, v in params.items()) or "the base scene"


# ------------------------------------------------------------------ running

def run_one(task: dict) -> dict:
    """Runs one task (a Run as a dict, with "threads", "duration", "outputs",
    "every", "folder") to the end: its row of the results. Runs in a worker
    process; never raises for what the run does (a blow-up or an error is a row)."""
    import socket

    from .cli import _Run
    from .scene import load_scene
    from .simulation import InstabilityError, Simulation

    row = _row(task, "ok", "")
    row.update(host=socket.gethostname(), pid=os.getpid())
    started = time.perf_counter()
    sim = None
    folder = Path(task["folder"])
    outputs = task["outputs"]
    keep = any(o != "summary" for o in outputs)
    scene = task["scene"]
    if "probes" not in outputs:  # (they change nothing of the run)
        scene = {k: v for k, v in scene.items() if k != "probes"}
    try:
        sim = Simulation(load_scene(scene), threads=task["threads"])
        if keep:
            folder.mkdir(parents=True, exist_ok=True)
            (folder / "scene.json").write_text(json.dumps(task["scene"], indent=2))

        class Args:  # what _Run reads of `sphfluid run`'s options
            out = folder if keep else None
            every = task["every"] if {"frames", "trajectory"} & set(outputs) else None
            checkpoint_every = task["duration"] if "checkpoint" in outputs else None
            quiet = True
            scene = str(folder / "scene.json")
            format = "npz"
            surface = False

        run = _Run(Args, sim, task["duration"])
        run.noted = True  # (no note of the run's length: the sweep shows its progress)
        track: list = []  # the trajectory: positions (float32) and ids at each frame time
        if "trajectory" in outputs:
            write = run.write_frame if "frames" in outputs else (lambda: None)

            def frame() -> None:
                write()
                track.append((sim.positions.astype("float32"), sim.ids.copy()))

            run.write_frame = frame  # type: ignore[method-assign]
        elif "frames" not in outputs:
            run.frame_times = {}
            run.write_frame = lambda: None  # type: ignore[method-assign]
        run.save_last_good_state = lambda: _save_last_good(sim, folder)  # type: ignore[method-assign]
        run.to_end()
        row.update(_summary(run))
        if "trajectory" in outputs:
            _save_trajectory(folder / "trajectory.npz", track)
    except InstabilityError as e:
        row.update(status="blow-up", error=str(e))
        if sim is not None:
            row.update(simulated_time=sim.time, steps=sim.step_count)
    except Exception as e:  # noqa: BLE001 (a run's failure is its row, never the sweep's end)
        row.update(status="error", error=f"{type(e).__name__}: {e}")
    row["wall_time"] = round(time.perf_counter() - started, 4)
    return row


def _row(task: dict, status: str, error: str) -> dict:
    """The start of a task's row: its place, key, status, parameters."""
    return {"run": task["index"], "key": task["key"], "status": status, "error": error,
            "threads": task["threads"], **{f"param:{k}": v for k, v in task["params"].items()}}


def _save_trajectory(path: Path, track: list) -> None:
    """The positions at every frame time, each frame's particles by id: times
    (frames,), positions (frames, particles, 2) float32, ids (particles,); a
    frame with other particles than the first (some left the domain) is
    marked by ids_changed (the frame it happened at), its positions cut."""
    import numpy as np

    from .output import replacing

    first = np.sort(track[0][1])
    frames, changed = [], -1
    for k, (x, ids) in enumerate(track):
        order = np.argsort(ids, kind="stable")
        if len(ids) != len(first) or not np.array_equal(ids[order], first):
            changed = k
            break
        frames.append(x[order])
    with replacing(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, positions=np.array(frames), ids=first, ids_changed=changed)


def _save_last_good(sim, folder: Path) -> None:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        sim.save_state(folder / "last_good_state.npz")
    except OSError:
        pass


def _summary(run) -> dict:
    sim, wall = run.sim, max(run.wall, 1e-9)
    steps = sim.step_count - run.first_step
    st = sim.stats()
    return {"steps": steps, "simulated_time": sim.time, "particles": sim.n_particles,
            "removed": sim.removed_particles, "max_density_error": run.max_err,
            "max_compression": run.max_comp, "max_speed": st["max_speed"],
            "retried_steps": sim.retried_steps,
            "mean_dt": (sim.time - run.start) / max(steps, 1),
            "particle_steps_per_s": round(run.particle_steps / wall)}


def read_results(path: Path) -> list[dict]:
    """The rows of a results table (the values as text), [] if there is none."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return list(csv.DictReader(f))
    except FileNotFoundError:
        return []


def write_results(path: Path, rows: Iterable[dict], columns: Iterable[str]) -> None:
    """The table, written whole (a temporary file renamed onto it)."""
    from .output import replacing

    rows = sorted(rows, key=lambda r: int(r["run"]))
    head = ["run", "status", *[f"param:{c}" for c in columns], *_SUMMARY, "error", "host",
            "pid", "threads", "key"]
    extra = sorted({k for r in rows for k in r} - set(head))
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=head + extra, lineterminator="\n")
    writer.writeheader()
    for r in rows:
        writer.writerow({k: _cell(v) for k, v in r.items()})
    with replacing(path) as tmp:
        tmp.write_text(buffer.getvalue(), encoding="utf-8")


def _cell(v: Any) -> Any:
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, (list, dict)):
        return json.dumps(v)
    return v


@dataclass
class Outcome:
    """What a call of run_sweep did."""

    table: Path
    ran: int = 0
    skipped: int = 0
    statuses: dict[str, int] = field(default_factory=dict)
    wall: float = 0.0


def run_sweep(sweep: Sweep, out: Path, *, workers: int | None = None, threads: int = 1,
              scheduler: str | None = None, progress: bool = True,
              on_row: Callable[[dict], None] | None = None) -> Outcome:
    """Runs the sweep's runs that out/results.csv does not hold as done, on a
    LocalCluster of `workers` processes (default: the cores / threads), on the
    scheduler at `scheduler`, or in this process (workers=0), each run on
    `threads` OpenMP threads; the table is rewritten after every run."""
    engine.check(workers, scheduler)
    out = Path(out).resolve()  # (workers elsewhere write to the same path)
    out.mkdir(parents=True, exist_ok=True)
    table = out / RESULTS
    rows = {r["key"]: r for r in read_results(table) if r.get("key")}
    keys = {run.index: sweep.key(run) for run in sweep.runs}
    results: dict[str, dict] = {}
    for run in sweep.runs:  # a kept row takes its run's place and parameters in this sweep
        row = rows.get(keys[run.index])
        if row is not None and row.get("status") in DONE:
            row = {k: v for k, v in row.items() if not k.startswith("param:")}
            row.update({"run": run.index, **{f"param:{k}": v for k, v in run.params.items()}})
            results[keys[run.index]] = row
    todo = [run for run in sweep.runs if keys[run.index] not in results]
    outcome = Outcome(table, skipped=len(sweep.runs) - len(todo))
    write_results(table, results.values(), sweep.columns)
    tasks = [{"index": r.index, "key": keys[r.index], "params": r.params, "scene": r.scene,
              "threads": threads, "duration": sweep.duration, "outputs": list(sweep.outputs),
              "every": sweep.every if sweep.every is not None else 1.0 / 30.0,
              "folder": str(sweep.folder(out, r))} for r in todo]
    written = time.perf_counter()
    started = time.perf_counter()
    bar = None
    if progress and tasks:
        from .progress import Runs

        bar = Runs(len(tasks))
    slots = [1]  # runs at a time (the engine says how many it has)

    def done(row: dict) -> None:
        nonlocal written
        results[row["key"]] = row
        outcome.ran += 1
        if outcome.ran == len(tasks) or time.perf_counter() - written > WRITE_EVERY:
            write_results(table, results.values(), sweep.columns)
            written = time.perf_counter()
        outcome.statuses[row["status"]] = outcome.statuses.get(row["status"], 0) + 1
        if on_row is not None:
            on_row(row)
        if bar is not None:
            failed = outcome.statuses.get("error", 0) + outcome.statuses.get("blow-up", 0)
            running = min(slots[0], len(tasks) - outcome.ran)
            bar.status(f"{running} running, {failed} failed")
            line = f"run {row['run']:>4}  {row['status']:<8} {_shown_params(_params(row))}"
            if row["status"] != "ok":
                line += f": {str(row['error'])[:120]}"
            bar.done(line)

    try:
        engine.execute(run_one, tasks, lambda place, row: done(row), workers=workers,
                       threads=threads, scheduler=scheduler,
                       failed=lambda place, e: _row(tasks[place], "error",
                                                    f"{type(e).__name__}: {e}"),
                       name=lambda place: f"run-{tasks[place]['key']}", slots=slots)
    finally:
        if bar is not None:
            bar.close()
        write_results(table, results.values(), sweep.columns)  # (an interrupted sweep too)
    outcome.wall = time.perf_counter() - started
    return outcome


def _params(row: dict) -> dict:
    return {k[len("param:"):]: v for k, v in row.items() if k.startswith("param:")}


# ----------------------------------------------------------------- command

def main(args) -> int:
    """`sphfluid sweep SPEC`: check the sweep, run what is missing, print the tally."""
    import sys

    sweep = load_sweep(args.spec)  # a SweepError: its problems, exit 2 (cli)
    out = Path(args.out) if args.out else Path(Path(args.spec).stem + ".sweep")
    if args.dry_run:
        for run in sweep.runs:
            print(f"run {run.index:>4}  {sweep.key(run)}  {_shown_params(run.params)}")
        print(f"{len(sweep.runs)} runs of {sweep.duration:g} s each; results would go to "
              f"{out / RESULTS}")
        return 0
    threads = args.threads or 1
    where = engine.where(args.workers, threads, args.scheduler)
    print(f"{Path(args.spec).name}: {len(sweep.runs)} runs of {sweep.duration:g} s, {where}, "
          f"{threads} thread(s) each; results in {out / RESULTS}", file=sys.stderr)
    outcome = run_sweep(sweep, out, workers=args.workers, threads=threads,
                        scheduler=args.scheduler, progress=not args.quiet)
    tally = ", ".join(f"{n} {s}" for s, n in sorted(outcome.statuses.items())) or "none run"
    print(f"{outcome.ran} run(s) in {outcome.wall:.1f} s ({tally}); {outcome.skipped} done "
          f"before and kept; table: {outcome.table}")
    return 1 if outcome.statuses.get("error") else 0
