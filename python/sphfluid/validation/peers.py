"""``sphfluid validate --peers``: PySPH's schemes on the cases it has, in the same run
as ours. Reads the driver benchmarks/peers/pysph_cases.py of a source checkout (it
runs each example in a subprocess and scores it with our cases' errors); writes its
runs as Results (rows of our tables, points of our plots) and, per case, whether a
point of ours has both a lower error and a lower wall time than each scheme's best.
"""
from __future__ import annotations

import math
import time
from pathlib import Path
from types import ModuleType

from ..bench import BenchmarksNotFoundError, benchmarks_dir, load_benchmark
from .cases import CASES, Result

DRIVER = "peers/pysph_cases.py"  # in the repository's benchmarks/ folder
DEFAULT_TIMEOUT = 3600.0  # s allowed per PySPH run, set-up and compilation included
# A run whose threads had the cores less of its wall time than this (its CPU time over
# threads x wall time) shared them with other jobs: with OpenMP every barrier then
# waits, and its wall time overstates its cost. The report flags it.
BUSY_SHARE = 0.8
PROGRESS_EVERY = 30.0  # s of wall time between the progress lines of one run


class PeersUnavailableError(RuntimeError):
    """PySPH cannot run here: no driver (an installed wheel), or PySPH does not import."""


def load(explicit: Path | None = None) -> tuple[ModuleType, str]:
    """The PySPH driver and the version of PySPH that runs here.

    Raises
    ------
    PeersUnavailableError
        With a one-line reason: no benchmarks/ folder, or PySPH not installed or
        failing to import (tried in a subprocess).
    """
    try:
        driver = load_benchmark(benchmarks_dir(explicit), DRIVER)
    except BenchmarksNotFoundError as e:
        raise PeersUnavailableError(str(e)) from None
    version, reason = driver.availability()
    if reason:
        raise PeersUnavailableError(f"PySPH cannot run here: {reason}")
    return driver, version


def to_result(r: dict, label: str) -> Result:
    """A driver's result (pysph_cases.run_case) as a row of our tables, `label` its
    method; the spacing is ours at its n (the examples may run in other units)."""
    wall = r["wall_s"] if math.isfinite(r["wall_s"]) else 0.0
    share = r["cpu_s"] / (r["threads"] * wall) if wall > 0 else math.nan
    return Result(r["case"], label, r["n"], CASES[r["case"]].spacing(r["n"]),
                  particles=int(r["particles"]), steps=int(r["steps"]), wall=wall,
                  error=float(r["error"]), metrics=dict(r["metrics"]), failure=r["failure"],
                  peer=r["peer"], note=r["note"], cpu_share=share)


def run_peers(driver: ModuleType, version: str, names: list[str], mode: str, threads: int,
              timeout: float, log, done=None) -> list[Result]:
    """Every scheme PySPH has for each named case, at the driver's resolutions for
    `mode`, one subprocess each; a line to `log` as each starts, one every
    PROGRESS_EVERY s in between, and one to `done` (by default `log`) as it
    ends. A run that times out or fails is a Result with its failure, never an
    exception."""
    results = []
    for name in names:
        if not driver.schemes(name):
            log(f"{name:13s} PySPH has no example of this case: ours only")
            continue
        for scheme in driver.schemes(name):
            for n in driver.resolutions(name, mode):
                results.append(_run_one(driver, version, name, scheme, n, threads, timeout,
                                        log, done or log))
    return results


def _run_one(driver: ModuleType, version: str, name: str, scheme: str, n: int, threads: int,
             timeout: float, log, done) -> Result:
    tag = f"{name:13s} {driver.label(scheme, version)} n={n:<4d}"
    log(f"{tag} running ({threads} threads, timeout {timeout:g} s)")
    shown = [time.monotonic()]

    def progress(done: float, seconds: float) -> None:
        if time.monotonic() - shown[0] >= PROGRESS_EVERY:
            shown[0] = time.monotonic()
            log(f"{tag} {100 * done:3.0f} % of its simulated time after {seconds:.0f} s")

    r = driver.run_case(name, scheme, n, threads, timeout, progress=progress)
    result = to_result(r, driver.label(scheme, r["version"] or version))
    outcome = (f"error {result.error:.4g}" if result.ok else f"FAILED: {result.failure}")
    busy = (f" (busy: its threads ran {result.cpu_share:.0%} of the time)"
            if result.cpu_share < BUSY_SHARE else "")
    done(f"{tag} {result.particles:7,d} particles {result.steps:7,d} steps "
        f"{result.wall:7.2f} s  {outcome}{busy}")
    return result


def busy_lines(results: list[Result]) -> list[str]:
    """A line for each peer run that shared the cores with other jobs."""
    return [f"- {r.method}, n = {r.n}: its threads ran {r.cpu_share:.0%} of its wall time "
            "(CPU time / (threads x wall time)): other jobs held the cores, and its wall "
            "time overstates its cost." for r in results
            if r.peer and r.cpu_share < BUSY_SHARE]


def best_point(runs: list[Result]) -> Result | None:
    """A peer's best point: its completed run of lowest error (None if none completed)."""
    done = [r for r in runs if r.ok]
    return min(done, key=lambda r: (r.error, r.wall)) if done else None


def beating(ours: list[Result], best: Result) -> Result | None:
    """Our completed run with both a lower error and a lower wall time than `best`
    (the fastest of them), or None."""
    better = [r for r in ours if not r.peer and r.ok and r.error < best.error
              and r.wall < best.wall]
    return min(better, key=lambda r: (r.wall, r.error)) if better else None


def _point(r: Result) -> str:
    busy = " (timed while other jobs held the cores)" if r.cpu_share < BUSY_SHARE else ""
    return f"n = {r.n}, error {r.error:.3g} in {r.wall:.2f} s{busy}"


def verdict(results: list[Result]) -> list[str]:
    """The report's lines, for one case, on whether a point of ours has both a lower
    error and a lower wall time than each peer scheme's best point: a summary, then a
    line per scheme. Nothing when no peer ran."""
    labels = list(dict.fromkeys(r.method for r in results if r.peer))
    if not labels:
        return []
    ours = [r for r in results if not r.peer]
    lines, beaten, not_beaten, no_run = [], [], [], []
    for label in labels:
        best = best_point([r for r in results if r.method == label])
        if best is None:
            no_run.append(label)
            lines.append(f"- {label}: no completed run to compare with.")
            continue
        ours_better = beating(ours, best)
        if ours_better is not None:
            beaten.append(label)
            lines.append(f"- {label}: best point {_point(best)}; beaten by "
                         f"{ours_better.method} {_point(ours_better)}.")
        else:
            not_beaten.append(label)
            done = [r for r in ours if r.ok]
            closest = (f" (our lowest error: {min(done, key=lambda r: r.error).method} "
                       f"{_point(min(done, key=lambda r: r.error))})" if done else "")
            lines.append(f"- {label}: best point {_point(best)}; no point of ours has both a "
                         f"lower error and a lower wall time{closest}.")
    if not_beaten:
        summary = f"no: not against {', '.join(not_beaten)}"
    elif beaten and no_run:
        summary = (f"yes against the {len(beaten)} that completed a run "
                   f"({', '.join(no_run)}: none completed)")
    elif beaten:
        summary = f"yes, against all {len(beaten)}"
    else:
        summary = "not decided: no peer run completed"
    return [f"**Against the peers** (a point of ours with both a lower error and a lower "
            f"wall time than each peer scheme's best point, its lowest error): {summary}.",
            "", *lines]
