"""`sphfluid bench --suite`: the dam break from ~1k to ~1M particles and the bare
loop (no walls, no viscosity, no tension), each on 1 and 2 threads, for every
method; time to solution of 1.0 s of the dam break against its front error; with
--peers, every configuration of the peers (PySPH, SPlisHSPlasH) that are installed,
run by benchmarks/peers/ of a source checkout. Writes the tables and a log-log plot
of time per step against N.

Every timed configuration runs in a fresh child process, so its peak memory is
its own, --repeat times (default 3) in rounds over all the configurations; the
median run is reported with the range. Bytes per particle: the solver's arrays
(``Solver.memory_bytes``, capacity included) / particles, and the process's
peak resident memory above what it held after its imports / particles (set-up
temporaries included).
"""
from __future__ import annotations

import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from .bench import (
    VARIANTS,
    BenchmarksNotFoundError,
    benchmarks_dir,
    front_error,
    load_benchmark,
    machine,
    thread_label,
    variant_scene,
    write_section,
)
from .metadata import source_line, target

SIZES = (1_000, 10_000, 100_000, 1_000_000)
PHASE_LABELS = {"sort": "sort", "neighbours": "neighbours + fluid density",
                "ghosts": "wall ghosts", "density": "wall density + EOS",
                "forces": "forces", "integrate": "integrate + walls + guard",
                "domain": "domain", "solve": "pressure solves"}


# The bare loop's steps, warm-up included: a free block without viscosity is
# unstable with the seed's EOS (measured: the guard stops it on energy at step 333
# at ~1,000 particles and at step 458 at ~10,000), so its cost is timed before that.
BARE_STEPS = 220


def bare_scene(n_target: int, method: str) -> dict:
    """The dam-break column with no walls, no viscosity, no tension and no
    gravity, in a domain with room around it: the cost of the bare SPH loop
    (timed over its first BARE_STEPS steps)."""
    scene = variant_scene(n_target, method)
    scene["name"] = f"Bare loop, {n_target:,} particles"
    scene["walls"] = []
    scene["fluid"]["viscosity"] = 0.0
    scene["gravity"] = [0.0, 0.0]  # a block at rest: nothing falls out of the domain
    scene["domain"] = {"min": [-1.0, -1.0], "max": [2.0, 3.0]}
    return scene


def steps_for(n: int) -> tuple[int, int]:
    """(warm-up, timed) steps: about 2e7 particle-steps timed, 20 to 2,000 steps."""
    timed = int(min(2000, max(20, 2e7 / n)))
    return max(5, timed // 10), timed


def measure_one(kind: str, method: str, n_target: int, threads: int) -> dict:
    """Time one configuration in this process (called in a child process)."""
    from .simulation import Simulation

    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB, after imports
    scene = bare_scene(n_target, method) if kind == "bare" else variant_scene(n_target, method)
    sim = Simulation(scene, threads=threads)
    warmup, steps = steps_for(sim.n_particles)
    if kind == "bare":
        warmup = min(warmup, BARE_STEPS // 10)
        steps = min(steps, BARE_STEPS - warmup)
    sim.step(warmup)
    sim._solver.reset_phase_seconds()
    start = time.perf_counter()
    sim.step(steps)
    wall = time.perf_counter() - start
    n = sim.n_particles
    out = {"kind": kind, "method": method, "threads": threads, "in_use": sim.threads_in_use,
           "particles": n,
           "steps": steps, "wall": wall, "steps_per_s": steps / wall,
           "pps": steps * n / wall, "ns_per_ps": 1e9 * wall / (steps * n),
           "phases_us": {k: 1e6 * v / steps for k, v in sim._solver.phase_seconds().items()},
           "pairs_per_particle": sim._solver.neighbour_pairs / max(n, 1),
           "peak_bytes_per_particle": 1024 * (resource.getrusage(
               resource.RUSAGE_SELF).ru_maxrss - base) / n,
           "bytes_per_particle": sum(sim._solver.memory_bytes.values()) / n}
    if kind == "dam":
        out["T"], out["Z"], out["Z_ref"] = front_error(sim)
    return out


def run_child(kind: str, method: str, n_target: int, threads: int, timeout: float) -> dict:
    env = dict(os.environ, OMP_NUM_THREADS=str(threads), OPENBLAS_NUM_THREADS="1")
    code = ("import json, sys; from sphfluid.bench_suite import measure_one; "
            f"print(json.dumps(measure_one({kind!r}, {method!r}, {n_target}, {threads})))")
    try:
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           env=env, timeout=timeout, check=False)
    except subprocess.TimeoutExpired:
        return {"error": f"over the {timeout:.0f} s time limit"}
    if p.returncode != 0:
        return {"error": (p.stderr.strip().splitlines() or ["crashed"])[-1]}
    return json.loads(p.stdout.strip().splitlines()[-1])


def median_of(runs: list[dict], key: str = "steps_per_s", higher_is_faster: bool = True) -> dict:
    """The median run of one configuration's repeats (of an even count, the slower
    of the two middle ones), with the range of `key` over the runs that completed
    and how many failed. All failed: the first failure."""
    done = [r for r in runs if "wall" in r]  # a failed run has no wall time
    if not done:
        return dict(runs[0], runs=len(runs), failed=len(runs))
    done.sort(key=lambda r: r[key], reverse=higher_is_faster)
    out = dict(done[len(done) // 2])
    out["range"] = (min(r[key] for r in done), max(r[key] for r in done))
    out["runs"] = len(runs)
    out["failed"] = len(runs) - len(done)
    return out


def time_to_solution(method: str, n_target: int, threads: int, end: float = 1.0) -> dict:
    """Wall time for `end` s of the dam break with adaptive steps, and its front
    error against Martin & Moyce (no shift; Z < 4)."""
    from .simulation import Simulation
    from .validation.cases import surge_front
    from .validation.reference import best_shift_front_error, mean_front_error

    scene = variant_scene(n_target, method)
    scene["solver"]["time_step"] = "auto"
    sim = Simulation(scene, threads=threads)
    times, fronts, wall = [0.0], [1.0], 0.0
    for t in np.linspace(0.01, end, round(end / 0.01)):
        begin = time.perf_counter()
        sim.advance_to(float(t))
        wall += time.perf_counter() - begin
        times.append(sim.time)
        fronts.append(surge_front(sim.positions, sim.scene.spacing))
    return {"method": method, "particles": sim.n_particles, "steps": sim.step_count,
            "wall": wall, "error": mean_front_error(times, fronts, 1.0, max_z=4.0),
            "shifted": best_shift_front_error(times, fronts, 1.0, max_z=4.0)}


def _ours_no_worse(ours: list[dict], error: float) -> dict | None:
    """Our quickest time-to-solution run (any method, any size) whose front error is
    no worse than `error`."""
    good = [m for m in ours if math.isfinite(error) and m["error"] <= error]
    return min(good, key=lambda m: m["wall"]) if good else None


def _versus(ours: list[dict], r) -> str:
    best = _ours_no_worse(ours, r.front_error)
    if best is None:
        return "none"
    return (f"{best['wall']:.2f} ({best['method']}, {best['particles']:,} particles; "
            f"{r.wall_s / best['wall']:.0f}x faster)")


def _peer_row(r, ours: list[dict]) -> str:
    return (f"| {r.name} {r.version} | {r.configuration} | {r.method} | {r.particles:,} | "
            f"{r.steps:,} | {r.wall_s:.1f} | {r.particle_steps_per_s / 1e6:.2f} M | "
            f"{r.front_error:.3f} | {_versus(ours, r)} | "
            f"{('crashed: ' + r.crashed + '; ') if r.crashed else ''}{r.note} |")


def fastest_configurations(results: list, ours: list[dict]) -> list[str]:
    """A line per peer: its fastest configuration among those that reached the end
    with a front error, and our fastest run to a front error no worse."""
    lines = []
    for name in dict.fromkeys(r.name for r in results):
        done = [r for r in results if r.name == name and not r.crashed
                and math.isfinite(r.front_error)]
        if not done:
            lines.append(f"- {name}: no configuration reached the end time.")
            continue
        r = min(done, key=lambda r: r.wall_s)
        lines.append(f"- {name}: `{r.configuration}`, {r.wall_s:.1f} s at front error "
                     f"{r.front_error:.3f}; ours to a front error no worse: {_versus(ours, r)}.")
    return lines


def run_peers(peers, n_target: int, end: float, ours: list[dict], log) -> list[str]:
    """The established codes on the same dam break (same spacing, end time and 2
    threads), every configuration of each one installed (docs/peers.md); a Markdown
    table beside ours, and each peer's fastest configuration. `peers` is the
    harness, benchmarks/peers/peers.py (load_peers)."""
    spacing = math.sqrt(2.0 / n_target)  # as dam_break_scene
    mine = [r for r in ours if abs(r["particles"] - n_target) < 0.2 * n_target]
    lines = [("| code | configuration | method | particles | steps | wall s | particle-steps/s "
              "| front error, no shift | our fastest to a front error no worse: wall s (ratio) "
              "| note |"),
             "|---|---|---|---:|---:|---:|---:|---:|---|---|"]
    results = []
    for name, reason in peers.available().items():
        if reason:
            lines.append(f"| {name} | | | | | | | | | skipped: {reason} |")
            log(f"peer {name}: skipped ({reason})")
            continue
        for configuration in peers.configurations(name):
            r = peers.run_peer(name, spacing=spacing, end_time=end, threads=2,
                               configuration=configuration)
            log(f"peer {name} {configuration}: {r.particles:,} particles, {r.steps:,} steps, "
                f"{r.wall_s:.1f} s, front error {r.front_error:.3f}"
                f"{', crashed: ' + r.crashed if r.crashed else ''}")
            results.append(r)
            lines.append(_peer_row(r, ours))
    if results:
        lines += ["", "Each peer's fastest configuration that reached the end time, and our "
                  "fastest run to a front error no worse:", "",
                  *fastest_configurations(results, ours)]
    if mine:
        lines += ["", "Ours at the same particle count: " + "; ".join(
            f"{m['method']} {m['wall']:.2f} s, {m['particles'] * m['steps'] / m['wall'] / 1e6:.2f} "
            f"M particle-steps/s, front error {m['error']:.3f}" for m in mine) + "."]
    return lines


def scaling_plot(rows: list[dict], path: Path) -> bool:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        return False
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    for method, colour in zip(VARIANTS, ("C0", "C1", "C2", "C3")):
        for kind, style in (("dam", "o-"), ("bare", "s--")):
            for threads, alpha in ((1, 0.45), (2, 1.0)):
                sel = sorted((r for r in rows if r["method"] == method and r["kind"] == kind
                              and r["threads"] == threads and "wall" in r),
                             key=lambda r: r["particles"])
                if sel:
                    ax.loglog([r["particles"] for r in sel],
                              [1e3 / r["steps_per_s"] for r in sel], style, color=colour,
                              alpha=alpha, label=f"{method}, {'dam break' if kind == 'dam' else 'bare loop'}, "
                                                 f"{threads} thread{'s' if threads > 1 else ''}")
    n = np.array([1e3, 1e6])
    ax.loglog(n, 1e-4 * n, "k:", lw=0.8, label="100 ns per particle (slope 1)")
    ax.set_xlabel("particles")
    ax.set_ylabel("wall time per step, ms")
    ax.set_title("Time per step against N", fontsize=10)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def throughput_table(rows: list[dict]) -> str:
    lines = [("| method | scene | particles | threads | steps | steps/s | range | "
             "particle-steps/s | ns/particle-step | parallel efficiency | neighbours/particle | "
             "bytes/particle (process peak) | front Z (M&M) at T |"),
             "|---|---|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---|"]
    one = {(r["method"], r["kind"], r["particles"]): r for r in rows
           if r.get("threads") == 1 and "wall" in r}
    for r in rows:
        if "wall" not in r:
            lines.append(f"| {r['method']} | {r['kind']} | ~{r['target']:,} | {r['threads']} | "
                         f"| failed: {r['error']} | | | | | | | |")
            continue
        ref = one.get((r["method"], r["kind"], r["particles"]))
        eff = (f"{r['steps_per_s'] / (r['threads'] * ref['steps_per_s']):.0%}"
               if ref and r.get("in_use", r["threads"]) > 1 else "")
        front = (f"{r['Z']:.3f} ({r['Z_ref']:.3f}) at {r['T']:.3f}" if "Z" in r else "")
        spread = ""
        if r.get("runs", 1) > 1:
            lo, hi = r["range"]
            spread = f"{lo:,.1f}–{hi:,.1f}" + (f" ({r['failed']} failed)" if r["failed"] else "")
        lines.append(
            f"| {r['method']} | {'dam break' if r['kind'] == 'dam' else 'bare loop'} | "
            f"{r['particles']:,} | {thread_label(r)} | {r['steps']:,} | {r['steps_per_s']:,.1f} | "
            f"{spread} | {r['pps'] / 1e6:.2f} M | {r['ns_per_ps']:.1f} | {eff} | "
            f"{r['pairs_per_particle']:.1f} | {r['bytes_per_particle']:.0f} "
            f"({r['peak_bytes_per_particle']:.0f}) | {front} |")
    return "\n".join(lines)


def phase_table(rows: list[dict]) -> str:
    names = list(PHASE_LABELS)
    lines = ["| method | scene | particles | threads | " + " | ".join(
        PHASE_LABELS[k] for k in names) + " |", "|---|---|---:|---:|" + "---:|" * len(names)]
    for r in rows:
        if "wall" not in r:
            continue
        per = {k: r["phases_us"].get(k, 0.0) / r["particles"] * 1e3 for k in names}
        lines.append(f"| {r['method']} | {r['kind']} | {r['particles']:,} | {thread_label(r)} | "
                     + " | ".join(f"{per[k]:.1f}" for k in names) + " |")
    return "\n".join(lines)


def load_peers(explicit: Path | None = None):
    """The peer harness, benchmarks/peers/peers.py of a source checkout (benchmarks_dir)."""
    return load_benchmark(benchmarks_dir(explicit), "peers/peers.py")


def _log(line: str) -> None:
    print(line, file=sys.stderr, flush=True)


def throughput_configs(methods: list[str], sizes: list[int]) -> list[tuple]:
    """(method, kind, n, threads) of the scaling table's runs."""
    return [(method, kind, n, threads) for method in methods for kind in ("dam", "bare")
            for n in (sizes if kind == "dam" else [s for s in sizes if s <= 100_000])
            for threads in (1, 2)]


def run_throughput(methods: list[str], sizes: list[int], repeat: int, log=_log) -> list[dict]:
    """The scaling table's runs: the dam break at every size and the bare loop up to
    100k, on 1 and 2 threads, each in a child process, `repeat` times in rounds; the
    median run of each configuration."""
    configs = throughput_configs(methods, sizes)
    # Rounds over all the configurations, so that a slow spell of the machine
    # falls on one run of many configurations rather than on all runs of one.
    runs: dict[tuple, list[dict]] = {c: [] for c in configs}
    for round_ in range(1, repeat + 1):
        for method, kind, n, threads in configs:
            r = run_child(kind, method, n, threads, timeout=1800)
            r.setdefault("method", method)
            r.setdefault("kind", kind)
            r.setdefault("threads", threads)
            r["target"] = n
            runs[(method, kind, n, threads)].append(r)
            log(f"[{round_}/{repeat}] {method:10s} {kind:4s} ~{n:>9,} {threads} thr: " + (
                f"{r['steps_per_s']:9.1f} steps/s {r['ns_per_ps']:7.1f} ns/particle-step "
                f"{r['bytes_per_particle']:5.0f} B/particle" if "wall" in r
                else f"failed: {r['error']}"))
    return [median_of(runs[c]) for c in configs]


def run_times_to_solution(methods: list[str], sizes: list[int], repeat: int,
                          log=_log) -> list[dict]:
    """1.0 s of the dam break on 2 threads for every method and size, `repeat` times
    in rounds; the run of median wall time of each."""
    configs = [(method, n) for method in methods for n in sizes]
    runs: dict[tuple, list[dict]] = {c: [] for c in configs}
    for round_ in range(1, repeat + 1):
        for method, n in configs:
            r = time_to_solution(method, n, 2)
            runs[(method, n)].append(r)
            log(f"[{round_}/{repeat}] time to solution {method} {r['particles']:,}: "
                f"{r['wall']:.2f} s, {r['steps']:,} steps, front error {r['error']:.3f}")
    return [median_of(runs[c], key="wall", higher_is_faster=False) for c in configs]


def tts_table(tts: list[dict]) -> list[str]:
    lines = [("| method | particles | steps | wall s (2 threads) | range | front error, "
              "no shift | best shift: error (shift) |"), "|---|---:|---:|---:|---|---:|---|"]
    for r in tts:
        s, e = r["shifted"]
        lo, hi = r["range"]
        lines.append(f"| {r['method']} | {r['particles']:,} | {r['steps']:,} | "
                     f"{r['wall']:.2f} | {lo:.2f}–{hi:.2f} | {r['error']:.3f} | "
                     f"{e:.3f} ({s:.2f}) |")
    return lines


def suite_report(args, rows: list[dict], tts: list[dict], repeat: int, start: float) -> str:
    """The suite's section of BENCHMARKS.md: the tables, and the plot (drawn here,
    into args.out) when matplotlib is installed."""
    from . import _core

    info = _core.build_info
    png = args.out / "bench_scaling.png"
    drew = scaling_plot(rows, png)
    rel = os.path.relpath(png, args.write.parent if args.write else Path("."))
    return "\n".join([
        f"Machine: {machine()}. {source_line()}. Build: {info['compiler']}, "
        f"{info['build_type']}, {target()}, OpenMP {info['openmp']}, {info['real']}. "
        f"Date: {time.strftime('%Y-%m-%d')}. Command: `sphfluid bench --suite"
        + (f" --method {args.method}" if getattr(args, "method_given", False) else "")
        + (f" --sizes {args.sizes}" if args.sizes else "")
        + (f" --tts-sizes {args.tts_sizes}" if getattr(args, "tts_sizes", None) else "")
        + (f" --repeat {repeat}" if repeat != 3 else "") + "` "
        f"({time.perf_counter() - start:.0f} s in all).",
        "",
        ("Fixed dt (the seed: 2e-4 s x dx/0.02 m; wcsph: 0.3 (h/2)/c0; dfsph: its adaptive "
        "step, water's viscosity), warm-up then about "
        "2e7 particle-steps timed (20 to 2,000 steps; the bare loop within its first "
        f"{BARE_STEPS} steps, as the seed's free block without viscosity blows up after "
        f"about 330), each configuration in a fresh process, {repeat} time(s) in rounds over "
        "all of them; the median run is reported, with the range of steps/s (time to "
        "solution: of wall time). seed-float: the seed with its "
        "pair forces in float (solver.pair_precision; docs/method-seed.md, \"Pair forces in single precision\"). \"2 (1 in use)\": "
        "below 1,000 "
        "particles the step runs on one thread whatever is asked. Bytes per particle: the "
        "solver's arrays (capacity included), and in brackets the process's peak resident "
        "memory above its state after the imports "
        "(set-up temporaries and memory the allocator keeps included), per particle."),
        "",
        throughput_table(rows),
        "",
        "Time per phase, nanoseconds per particle per step:",
        "",
        phase_table(rows),
        "",
        ("Time to solution: 1.0 s of the dam break, adaptive dt (cfl 0.4), 2 threads; the "
        "front error is the mean |dZ| against Martin & Moyce's Table 2 over T < 3.2 "
        "(the front reaches the far wall), the peers' 0.25-0.31 being the mark to meet."),
        "",
        *tts_table(tts),
        "",
        ("The established codes on the same dam break: `sphfluid bench --suite --peers` "
         "(the next section, kept when the suite runs without them)."),
        "",
        *([f"![time per step against N]({rel})", ""] if drew else []),
    ])


def peers_report(peers, tts: list[dict], log=_log) -> str:
    """The peers' section of BENCHMARKS.md: every configuration of the installed
    peers on the 10k dam break, beside our time-to-solution runs."""
    return "\n".join([
        (f"Machine: {machine()}. {source_line()}. Date: {time.strftime('%Y-%m-%d')}. "
         "Command: `sphfluid bench --suite --peers`, in the environment of docs/peers.md. The dam break at "
         "~10,000 particles, 1.0 s, 2 threads, each code in its own process; our rows "
         "are the time-to-solution runs of the same command."),
        "",
        *run_peers(peers, 10_000, 1.0, tts, log),
        ""])


def main(args) -> int:
    peers = None
    if args.peers:  # before the long run: a wheel has no peer drivers
        try:
            peers = load_peers(args.benchmarks_dir)
        except BenchmarksNotFoundError as e:
            print(f"error: --peers: {e}", file=sys.stderr)
            return 2
    sizes = [int(s) for s in args.sizes.split(",")] if args.sizes else list(SIZES)
    tts_sizes = [int(n) for n in (args.tts_sizes or "1000,3000,10000").split(",")]
    methods = [args.method] if args.method_given else list(VARIANTS)
    start = time.perf_counter()
    repeat = max(1, args.repeat)
    from .progress import Runs

    total = repeat * (len(throughput_configs(methods, sizes)) + len(methods) * len(tts_sizes))
    with Runs(total) as runs:
        rows = run_throughput(methods, sizes, repeat, log=runs.done)
        tts = run_times_to_solution(methods, tts_sizes, repeat, log=runs.done)
    text = suite_report(args, rows, tts, repeat, start)
    print(text)
    if args.write:
        write_section(args.write, text, tag="bench suite")
        _log(f"wrote {args.write}")
    if peers is not None:
        peer_text = peers_report(peers, tts)
        print(peer_text)
        if args.write:
            write_section(args.write, peer_text, tag="bench peers")
    return 0
