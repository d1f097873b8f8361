"""Training data for learned simulators: the trajectories of a sweep's runs, in
the layout LagrangeBench reads (docs/datasets.md).

``sphfluid dataset SPEC --out DIR`` runs the sweep file SPEC (with its
"dataset" section: the trajectories per split, the time between stored
positions) through the sweep engine, each run keeping its trajectory, into
``DIR/sweep/``, then
writes ``DIR/train.h5``, ``valid.h5``, ``test.h5`` and ``metadata.json``:

- each split file holds one group per trajectory, ``00000``, ``00001``, ...,
  with ``position`` (frames, particles, 2; float32, gzip) and ``particle_type``
  (particles; int32): the fluid (type 0, by particle id) and then the walls as
  particles (type 1, a wall whose surface moves 2) one spacing apart along
  each segment, the same at every frame;
- ``metadata.json`` has the keys LagrangeBench's loader and models read
  (bounds, periodic_boundary_conditions, default_connectivity_radius, dim, dx,
  dt, write_every, num_particles_max, the velocity and acceleration means and
  standard deviations) and describes the runs.

The layout follows LagrangeBench v0.2.0 (commit b880a6c; its data loader
lagrangebench/data/data.py and its generator data_gen/lagrangebench_data/
gen_dataset.py, read, not copied). A trajectory must keep every particle and
have the first trajectory's particle count (the arrays have one shape): runs
the guard stops, runs that fail and runs that lose particles are left out and
listed in metadata.json, and the next runs take their place.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from .sweep import Sweep, SweepError, load_sweep, read_results, run_sweep

SPLITS = ("train", "valid", "test")
FLUID, WALL, MOVING_WALL = 0, 1, 2  # LagrangeBench's particle types
CONNECTIVITY = 1.45  # the connectivity radius in spacings, as LagrangeBench's datasets


def wall_particles(scene) -> tuple[np.ndarray, np.ndarray]:
    """Points one spacing apart (at most) along each wall segment, ends included
    and shared ends once: (positions (m, 2), types (m,))."""
    points: dict[tuple[int, int], tuple[tuple[float, float], int]] = {}
    grid = scene.spacing * 1e-6  # ends closer than this are one point
    for k, (a, b) in enumerate(scene.walls):
        a, b = np.asarray(a, float), np.asarray(b, float)
        n = max(1, math.ceil(np.hypot(*(b - a)) / scene.spacing - 1e-9))
        moving = bool(scene.wall_velocities) and any(scene.wall_velocities[k])
        for t in np.linspace(0.0, 1.0, n + 1):
            p = a + t * (b - a)
            key = (round(p[0] / grid), round(p[1] / grid))
            if key not in points or moving:
                points[key] = ((float(p[0]), float(p[1])), MOVING_WALL if moving else WALL)
    if not points:
        return np.zeros((0, 2)), np.zeros(0, np.int32)
    xy, kinds = zip(*points.values())
    return np.array(xy), np.array(kinds, np.int32)


def _trajectory(folder: Path) -> tuple[np.ndarray | None, str]:
    """The fluid's positions (frames, particles, 2) by particle id from a run's
    trajectory.npz, or None and why not."""
    try:
        with np.load(folder / "trajectory.npz") as z:
            positions, changed = z["positions"], int(z["ids_changed"])
    except OSError:
        return None, "no trajectory"
    if changed >= 0:
        return None, f"particles left the domain (frame {changed})"
    return positions, ""


def _statistics(trajectories: list[np.ndarray], box: np.ndarray | None) -> dict[str, list]:
    """LagrangeBench's normalisation of the fluid's motion: velocity the change
    of position from one stored frame to the next (the minimum image across a
    periodic axis), acceleration the change of that velocity, both per frame
    (not divided by a time). The mean: each trajectory's mean over frames and
    particles, averaged over the trajectories; the standard deviation: the root
    of the trajectories' mean squared deviations from that mean, averaged (a
    value below 1e-7 becomes 1), as LagrangeBench's generator computes them."""
    motions = []
    for r in trajectories:
        v = np.diff(r.astype(np.float64), axis=0)
        if box is not None:
            v -= box * np.round(v / np.where(box > 0, box, 1.0))
        motions.append((v.reshape(-1, 2), np.diff(v, axis=0).reshape(-1, 2)))
    stats: dict[str, list] = {}
    for k, name in enumerate(("vel", "acc")):
        parts = [m[k] for m in motions if len(m[k])]
        mean = np.mean([p.mean(0) for p in parts], 0) if parts else np.zeros(2)
        msd = [((p - mean) ** 2).mean(0) for p in parts]
        std = np.sqrt(np.mean(msd, 0)) if parts else np.ones(2)
        std = np.where(std < 1e-7, 1.0, std)
        stats[f"{name}_mean"] = [float(x) for x in mean]
        stats[f"{name}_std"] = [float(x) for x in std]
    return stats


def _time_step(scene: dict, every: float) -> tuple[float, int]:
    """(dt, write_every): the solver's fixed step and the steps between stored
    frames; with an adaptive step, (every, 1)."""
    step = scene.get("solver", {}).get("time_step", "auto")
    if isinstance(step, (int, float)):
        k = round(every / step)
        if k >= 1 and abs(k * step - every) <= 1e-9 * every:
            return float(step), int(k)
    return float(every), 1


def build(sweep: Sweep, out: Path, *, workers: int | None = None, threads: int = 1,
          scheduler: str | None = None, progress: bool = True) -> dict[str, Any]:
    """Runs the sweep (what DIR/sweep/ lacks) and writes the dataset; returns
    the metadata written."""
    from .output import replacing
    from .scene import load_scene

    wanted, every = _wanted(sweep)
    sweep.outputs = tuple(dict.fromkeys([*sweep.outputs, "trajectory"]))
    sweep.every = every
    work = Path(out) / "sweep"
    run_sweep(sweep, work, workers=workers, threads=threads, scheduler=scheduler,
              progress=progress)
    taken, left_out = _choose(sweep, work, sum(wanted.values()))
    Path(out).mkdir(parents=True, exist_ok=True)
    split_of: dict[str, list[int]] = {}
    k = 0
    for split in SPLITS:
        part = taken[k:k + wanted[split]]
        k += len(part)
        split_of[split] = [run.index for run, *_ in part]
        _write_split(Path(out) / f"{split}.h5", part)
    first = load_scene(taken[0][0].scene if taken else sweep.runs[0].scene)
    metadata = _metadata(sweep, first, taken, every)
    metadata["num_trajs_train"] = len(split_of["train"])
    metadata["num_trajs_valid"] = len(split_of["valid"])
    metadata["num_trajs_test"] = len(split_of["test"])
    metadata["sphfluid"].update(
        runs=split_of, left_out=left_out,
        missing={s: wanted[s] - len(split_of[s]) for s in SPLITS if wanted[s] > len(split_of[s])})
    with replacing(Path(out) / "metadata.json") as tmp:
        tmp.write_text(json.dumps(metadata, indent=2) + "\n", encoding="utf-8")
    return metadata


def _wanted(sweep: Sweep) -> tuple[dict[str, int], float]:
    """The trajectories each split wants and the time between frames, checked
    against the sweep."""
    spec = sweep.dataset
    if spec is None:
        raise SweepError(['dataset: required by sphfluid dataset ({"splits": {"train": N, '
                          '"valid": N, "test": N}, "every": DT})'], sweep.name)
    wanted = {s: int(spec["splits"].get(s, 0)) for s in SPLITS}
    if sum(wanted.values()) > len(sweep.runs):
        raise SweepError([f"dataset.splits: {sum(wanted.values())} trajectories, but the sweep "
                          f"makes {len(sweep.runs)} runs (raise samples)"], sweep.name)
    every = float(spec["every"])
    if every > sweep.duration:
        raise SweepError([f"dataset.every: {every:g} s is longer than the runs "
                          f"({sweep.duration:g} s)"], sweep.name)
    return wanted, every


Taken = tuple[Any, np.ndarray, np.ndarray, np.ndarray]  # run, fluid positions, walls, wall types


def _choose(sweep: Sweep, work: Path, needed: int) -> tuple[list[Taken], list[dict]]:
    """The first `needed` runs that ended ok with the first one's particles, in
    the sweep's order, and the runs left out on the way, each with why."""
    from .scene import load_scene

    rows = {int(r["run"]): r for r in read_results(work / "results.csv")}
    taken: list[Taken] = []
    left_out: list[dict] = []
    count = None  # fluid and wall particles of the first trajectory
    for run in sweep.runs:
        if len(taken) == needed:
            break
        row = rows.get(run.index, {})
        why = "" if row.get("status") == "ok" else (
            f"{row.get('status', 'not run')}: {row.get('error', '')}".strip(": "))
        positions = None
        if not why:
            positions, why = _trajectory(sweep.folder(work, run))
        walls, kinds = wall_particles(load_scene(run.scene))
        if not why and count is not None and (positions.shape[1], len(walls)) != count:
            why = (f"{positions.shape[1]} fluid and {len(walls)} wall particles, not the first "
                   f"trajectory's {count[0]} and {count[1]}")
        if why:
            left_out.append({"run": run.index, "params": run.params, "reason": why})
            continue
        count = (positions.shape[1], len(walls))
        taken.append((run, positions, walls, kinds))
    return taken, left_out


def _write_split(path: Path, part: list[Taken]) -> None:
    """One split's HDF5 file: a group per trajectory, fluid then wall particles."""
    import h5py

    from .output import replacing

    with replacing(path) as tmp:
        with h5py.File(tmp, "w") as f:
            for j, (_, fluid, w, wk) in enumerate(part):
                frames = len(fluid)
                xy = np.concatenate([fluid, np.broadcast_to(w, (frames, *w.shape))], axis=1)
                g = f.create_group(f"{j:05d}")
                g.create_dataset("position", data=xy.astype(np.float32), compression="gzip")
                g.create_dataset("particle_type", data=np.concatenate(
                    [np.full(fluid.shape[1], FLUID, np.int32), wk]))


def _metadata(sweep: Sweep, first, taken: list[Taken], every: float) -> dict[str, Any]:
    """metadata.json but for the splits' counts and runs (build fills them in)."""
    from . import __version__

    periodic = [bool(p) for p in first.periodic]
    lo, hi = np.array(first.domain_min, float), np.array(first.domain_max, float)
    box = np.where(periodic, hi - lo, 0.0) if any(periodic) else None
    frames = len(taken[0][1]) if taken else 0
    dt, write_every = _time_step((taken[0][0] if taken else sweep.runs[0]).scene, every)
    fluid, walls = (taken[0][1].shape[1], len(taken[0][2])) if taken else (0, 0)
    dx = first.spacing
    return {
        "case": sweep.dataset.get("case", "SPH"),
        "solver": f"sphfluid {first.method}",
        "dim": 2,
        "dx": dx,
        "dt": dt,
        "write_every": write_every,
        "t_end": sweep.duration,
        "sequence_length_train": frames,
        "sequence_length_test": frames,
        "num_trajs_train": 0,
        "num_trajs_valid": 0,
        "num_trajs_test": 0,
        "num_particles_max": fluid + walls,
        "periodic_boundary_conditions": periodic,
        "bounds": [[float(lo[0]), float(hi[0])], [float(lo[1]), float(hi[1])]],
        "default_connectivity_radius": float(f"{CONNECTIVITY * dx:.2g}"),
        **_statistics([p for _, p, *_ in taken], box),
        "viscosity": first.viscosity,
        "g_ext_magnitude": float(np.hypot(*first.gravity)),
        "sphfluid": {"version": __version__, "sweep": sweep.name, "fluid_particles": fluid,
                     "wall_particles": walls, "runs": {}, "left_out": [], "missing": {}},
    }


def main(args) -> int:
    """`sphfluid dataset SPEC --out DIR`."""
    import sys

    sweep = load_sweep(args.spec)
    try:
        import h5py  # noqa: F401
    except ImportError:
        print('error: sphfluid dataset writes HDF5 with h5py: pip install "sphfluid[dataset]"',
              file=sys.stderr)
        return 2
    out = Path(args.out)
    print(f"{Path(args.spec).name}: {len(sweep.runs)} runs of {sweep.duration:g} s; the runs in "
          f"{out / 'sweep'}, the dataset in {out}", file=sys.stderr)
    meta = build(sweep, out, workers=args.workers, threads=args.threads or 1,
                 scheduler=args.scheduler, progress=not args.quiet)
    info = meta["sphfluid"]
    for item in info["left_out"]:
        print(f"left out: run {item['run']}: {item['reason']}", file=sys.stderr)
    sizes = ", ".join(f"{s} {meta[f'num_trajs_{s}']}" for s in SPLITS)
    print(f"{sizes} trajectories of {meta['sequence_length_train']} frames, "
          f"{info['fluid_particles']} fluid + {info['wall_particles']} wall particles; "
          f"{len(info['left_out'])} run(s) left out; {out / 'metadata.json'}")
    if info["missing"]:
        print("error: too few runs made a trajectory: missing " + ", ".join(
            f"{n} {s}" for s, n in info["missing"].items()) + " (raise samples)", file=sys.stderr)
        return 1
    return 0
