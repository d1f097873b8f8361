"""The `sphfluid` command: run | view | record | check | schema | bench | stress | validate |
fuzz.

Every user mistake ends in one clear message on stderr and a non-zero exit
code: 2 for bad input (scene, arguments, files), 3 for a numerical blow-up.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
import time
from pathlib import Path

EXIT_BAD_INPUT = 2
EXIT_UNSTABLE = 3


def _positive(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (x > 0 and math.isfinite(x)):
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return x


def _count(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if n < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text}")
    return n


def _parser() -> argparse.ArgumentParser:
    from . import __version__

    p = argparse.ArgumentParser(prog="sphfluid", description="2D SPH fluid simulator.")
    p.add_argument("--version", action="version", version=f"sphfluid {__version__}")
    sub = p.add_subparsers(dest="command", required=True,
                           metavar="{run,view,record,check,schema,bench,stress,validate,sweep,dataset,"
                                   "fuzz}")
    _add_run(sub)
    _add_view(sub)
    _add_record(sub)
    _add_check(sub)
    _add_schema(sub)
    _add_bench(sub)
    _add_stress(sub)
    _add_validate(sub)
    _add_sweep(sub)
    _add_dataset(sub)
    _add_fuzz(sub)
    return p


def _engine_options(p) -> None:
    """Where a sweep's runs run (sweep, dataset)."""
    p.add_argument("--workers", type=_count, default=None,
                   help="local worker processes (default: the cores / --threads); 0 runs the "
                        "runs one after another in this process")
    p.add_argument("--threads", type=_count, default=1, help="OpenMP threads per run (default 1)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (tcp://host:8786) instead of a local cluster")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def _matrix_options(p) -> None:
    """Where a report's runs run (stress, validate): by default one after another
    in this process, the tables as ever; on Dask with --workers or --scheduler."""
    p.add_argument("--workers", type=_count, default=0,
                   help="run the runs on a local Dask cluster of this many worker processes "
                        "(pip install \"sphfluid[sweep]\"; default 0: one after another in "
                        "this process). Wall times then share the cores: compare them within "
                        "one run")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="run the runs on an existing Dask scheduler (tcp://host:8786)")


def _add_dataset(sub) -> None:
    d = sub.add_parser("dataset", help="trajectories for learned simulators (docs/datasets.md)",
                       description="Run the sweep file SPEC (with its \"dataset\" section) and "
                                   "write its runs' trajectories in LagrangeBench's layout: "
                                   "DIR/train.h5, valid.h5, test.h5 and metadata.json.")
    d.add_argument("spec", help="the sweep file (JSON, docs/sweeps.md, docs/datasets.md)")
    d.add_argument("--out", metavar="DIR", required=True, help="the dataset's folder")
    _engine_options(d)


def _add_sweep(sub) -> None:
    w = sub.add_parser("sweep", help="run a parameter sweep of a scene (docs/sweeps.md)",
                       description="Run the runs of the sweep file SPEC that DIR/results.csv "
                                   "does not hold yet, as tasks on Dask distributed (a local "
                                   "cluster of worker processes by default), one row of "
                                   "results per run.")
    w.add_argument("spec", help="the sweep file (JSON, docs/sweeps.md)")
    w.add_argument("--out", metavar="DIR", help="where results.csv and the runs' outputs go "
                                                "(default: SPEC's name + .sweep)")
    _engine_options(w)
    w.add_argument("--dry-run", action="store_true", help="list the runs, run nothing")


def _add_fuzz(sub) -> None:
    f = sub.add_parser("fuzz", help="broken scenes and bad API calls: no traceback, hang or crash",
                       description="Run CASES seeded cases (docs/reliability.md): mutations "
                                   "of the scenes in --scenes (wrong types, NaN, infinities, "
                                   "huge and tiny numbers, nulls, nesting, degenerate walls "
                                   "and regions), loaded, checked and stepped; and bad "
                                   "arguments to a Simulation's methods. Each in a worker "
                                   "process under a memory limit; prints a table of "
                                   "outcomes and the bad cases (traceback, hang, crash, "
                                   "memory). Exit code 1 if any case is bad.")
    f.add_argument("--cases", type=_count, default=1000, help="cases to run (default 1000)")
    f.add_argument("--seed", type=int, default=0, help="seed of the cases (default 0)")
    f.add_argument("--scenes", type=Path, default=Path("scenes"),
                   help="the scenes the scene cases mutate (default: ./scenes)")
    f.add_argument("--timeout", type=float, default=60.0,
                   help="seconds a case may take before it counts as a hang (default 60)")
    f.add_argument("--case", metavar="KIND:INDEX",
                   help="run one case here and show it (scene:12 or api:7)")
    f.add_argument("--verbose", action="store_true", help="a line for every case")


def _add_run(sub) -> None:
    r = sub.add_parser("run", help="simulate a scene headless",
                       description="Simulate a scene without a window and print a summary.")
    r.add_argument("scene", help="scene JSON file")
    r.add_argument("--duration", type=_positive, help="simulated seconds (default: the scene's)")
    r.add_argument("--out", type=Path, help="write frames into this folder")
    r.add_argument("--format", choices=("npz", "vtk"),
                   help="frames as .npz files (the default), or as VTK .vtu files with a "
                        "frames.pvd collection for ParaView")
    r.add_argument("--surface", action="store_true",
                   help="with --out: each frame's liquid outline too, as surface_NNNNN.svg "
                        "and, with --format vtk, as polylines in surface_NNNNN.vtu (part 2 "
                        "of frames.pvd)")
    r.add_argument("--every", type=_positive,
                   help="simulated seconds between frames (default 1/30 s)")
    r.add_argument("--checkpoint-every", type=_positive, metavar="T",
                   help="write DIR/checkpoint.npz (with --out DIR) every T simulated seconds "
                        "and at the end, replacing the last one")
    r.add_argument("--resume", type=Path, metavar="CHECKPOINT",
                   help="continue from a checkpoint written for this scene, to the same end "
                        "(frames continue in --out)")
    r.add_argument("--log", type=Path, metavar="FILE",
                   help="write health counters as JSON Lines (run.jsonl) at each frame and "
                        "checkpoint time, or every hundredth of the run without --out: dt and "
                        "its limiter, density error, energies, particles removed, retried "
                        "steps, guard margins (docs/output.md); --resume appends")
    r.add_argument("--threads", type=_count, help="OpenMP threads (default: all cores)")
    r.add_argument("--quiet", action="store_true", help="no progress bar")
    _add_no_check(r)


def _add_view(sub) -> None:
    v = sub.add_parser("view", help="watch a scene in a window",
                       description="Run a scene in a pygame window. Keys: space pause, "
                                   "S or right arrow one step, R reset, Esc or Q quit.")
    v.add_argument("scene", help="scene JSON file")
    v.add_argument("--frames", type=_count, help="close after this many frames")
    v.add_argument("--screenshot", type=Path, help="save the last frame as a PNG")
    v.add_argument("--steps-per-frame", type=_count, default=None,
                   help="native steps per drawn frame (default: real time at 60 fps)")
    v.add_argument("--size", default="1000x700", help="window size WxH in pixels")
    v.add_argument("--threads", type=_count, help="OpenMP threads (default: all cores)")
    v.add_argument("--mode", choices=("speed", "pressure", "density", "surface"),
                   default="speed", help="colour mode (keys 1-4 switch it live)")
    _add_no_check(v)


def _add_no_check(p) -> None:
    p.add_argument("--no-check", action="store_true",
                   help="skip the scene check at the start (sphfluid check: its warnings are "
                        "printed, its errors stop the run), e.g. to watch a too-large time step "
                        "blow up")


def _add_record(sub) -> None:
    rec = sub.add_parser("record", help="render a scene to PNG frames, a GIF or an MP4",
                         description="Render frames headless (no display needed).")
    rec.add_argument("scene", help="scene JSON file")
    rec.add_argument("--out", type=Path, required=True,
                     help="a folder for PNG frames, a .gif file, or an .mp4 video (needs "
                          "imageio-ffmpeg: pip install \"sphfluid[video]\")")
    rec.add_argument("--duration", type=_positive, help="simulated seconds (default: the scene's)")
    rec.add_argument("--fps", type=_positive, default=30.0,
                     help="frames per simulated second (a GIF or MP4 plays them in real time)")
    rec.add_argument("--mode", choices=("speed", "pressure", "density", "surface"),
                     default="speed")
    rec.add_argument("--size", default="800x600", help="frame size WxH in pixels")
    rec.add_argument("--threads", type=_count, help="OpenMP threads (default: all cores)")
    rec.add_argument("--quiet", action="store_true", help="no progress bar")


def _add_check(sub) -> None:
    c = sub.add_parser("check", help="check a scene before running it",
                       description="Load a scene (its errors by JSON path), validate it "
                                   "against the JSON Schema and what it cannot say, then "
                                   "check its initial particles, walls and time step: "
                                   "particles outside the domain, overlapping a wall or "
                                   "another region, gaps between walls narrower than two "
                                   "spacings, a fixed time step above the stability limit. "
                                   "Prints each finding as error: or warning: with its JSON "
                                   "path, then the particle count, memory and steps, and the "
                                   "run time from timing the first steps. Exit code 0 "
                                   "without errors, 2 with.")
    c.add_argument("scene", help="scene JSON file")
    c.add_argument("--threads", type=_count,
                   help="OpenMP threads for the timed steps (default: all cores)")


def _add_schema(sub) -> None:
    sub.add_parser("schema", help="print the scene format's JSON Schema",
                   description="Print the JSON Schema of the scene format (draft 2020-12) to "
                               "stdout. Save it and point a scene's \"$schema\" key at it "
                               "for an editor to check and complete the scene as it is typed.")


def _add_bench(sub) -> None:
    b = sub.add_parser("bench", help="time the dam break at ~10k particles",
                       description="Dam break, fixed dt, 1 and 2 threads; prints steps/s and "
                                   "particle-steps/s and can write BENCHMARKS.md.")
    b.add_argument("--particles", type=_count, default=10_000)
    b.add_argument("--steps", type=_count, default=1000)
    b.add_argument("--warmup", type=_count, default=100)
    b.add_argument("--threads", default="1,2", help="comma-separated thread counts")
    b.add_argument("--method", choices=("seed", "wcsph", "dfsph"), default="seed",
                   help="the method to time (the same fixed dt for both)")
    b.add_argument("--pair-precision", default="double", metavar="PRECISION",
                   help="the seed's pair forces in double (default) or float, or both as "
                        "double,float (interleaved, one table)")
    b.add_argument("--surface-tension", type=float, default=0.0, metavar="SIGMA",
                   help="surface tension coefficient in N/m (default 0: the dam break as "
                        "bundled; with it, what a scene with tension costs)")
    b.add_argument("--repeat", type=_count, default=3,
                   help="runs per thread count, interleaved (with --suite: per "
                        "configuration, in rounds); the median is reported")
    b.add_argument("--write", type=Path, help="write the table into this Markdown file")
    b.add_argument("--draw", action="store_true",
                   help="instead: time drawing one viewer frame in each colour mode")
    b.add_argument("--guard-cost", action="store_true",
                   help="instead: time the step with and without the blow-up guard")
    b.add_argument("--suite", action="store_true",
                   help="instead: the dam break at ~1k to ~1M particles and the bare loop, "
                        "1 and 2 threads, every method (or --method), peak memory, time to "
                        "solution, and a log-log plot (tens of minutes)")
    b.add_argument("--sizes", help="--suite: comma-separated particle counts "
                                   "(default 1000,10000,100000,1000000)")
    b.add_argument("--tts-sizes", help="--suite: particle counts of the time-to-solution "
                                       "runs (default 1000,3000,10000)")
    b.add_argument("--out", type=Path, default=Path("docs"),
                   help="--suite: folder for the plot (default docs)")
    b.add_argument("--peers", action="store_true",
                   help="--suite: also run PySPH and SPlisHSPlasH on the same dam break "
                        "when installed (docs/peers.md)")
    _add_benchmarks_dir(b, "the peer drivers (--peers) and the reference loop")


def _add_benchmarks_dir(p, holding: str) -> None:
    """--benchmarks-dir: where a source checkout's benchmarks/ folder is (bench.benchmarks_dir)."""
    p.add_argument("--benchmarks-dir", type=Path, metavar="DIR",
                   help=f"the repository's benchmarks/ folder: {holding} (default: "
                        "$SPHFLUID_BENCHMARKS, else the one beside a source checkout's "
                        "package)")


def _add_stress(sub) -> None:
    s = sub.add_parser("stress", help="stability matrix and violent scenes",
                       description="Sweep k x dt for the seed method on the dam break and the "
                                   "splash (fixed and adaptive dt), then violent scenes (and, with "
                                   "--full, the bundled scenes with each method); report "
                                   "stable / caught by the guard / silent failures.")
    mode = s.add_mutually_exclusive_group()
    mode.add_argument("--quick", action="store_true", help="small sweep (default, minutes)")
    mode.add_argument("--full", action="store_true", help="the whole matrix (tens of minutes)")
    s.add_argument("--out", type=Path, default=Path("."), help="folder for the heat-map PNGs")
    s.add_argument("--pair-precision", choices=("double", "float"), default="double",
                   help="the seed's pair forces in double (default) or float (its own report "
                        "section and heat maps)")
    s.add_argument("--write", type=Path, help="write the table into this Markdown file")
    s.add_argument("--scenes", type=Path, default=Path("scenes"),
                   help="with --full, also run every scene in this folder as shipped and with "
                        "each method (default: ./scenes; skipped when absent, and then "
                        "--write is refused)")
    s.add_argument("--threads", type=_count,
                   help="OpenMP threads per run (default: all cores; 1 on Dask)")
    _matrix_options(s)


def _add_validate(sub) -> None:
    from .validation.cases import CASES, CHOICES

    v = sub.add_parser("validate", help="accuracy against known answers, with run times",
                       description="Run the validation cases (hydrostatic tank, dam break vs "
                                   "Martin & Moyce, its pressure on the far wall vs Buchner, "
                                   "Poiseuille, Taylor-Green, droplets, lid-driven cavity) at "
                                   "several resolutions for every method; print a table per "
                                   "case with the error and the wall time, plot error against "
                                   "run time. --quick checks each error against its bound "
                                   "(exit 1 when one is over). --peers adds PySPH's schemes "
                                   "on the same cases.")
    vmode = v.add_mutually_exclusive_group()
    vmode.add_argument("--quick", action="store_true",
                       help="small resolutions, checked against bounds (default, seconds)")
    vmode.add_argument("--full", action="store_true",
                       help="the real measurement (finer resolutions, minutes)")
    v.add_argument("--case", action="append", choices=list(CASES),
                   help="run only this case (repeatable)")
    v.add_argument("--method", action="append", choices=CHOICES,
                   help="run only this method (repeatable; seed-float: the seed with its pair "
                        "forces in float, solver.pair_precision; dfsph runs on request only)")
    v.add_argument("--threads", type=_count,
                   help="OpenMP threads per run (default: all cores; 1 on Dask)")
    _matrix_options(v)
    v.add_argument("--out", type=Path, default=Path("docs/validation"),
                   help="folder for the plots (default docs/validation)")
    v.add_argument("--write", type=Path, help="write the tables into this Markdown file")
    v.add_argument("--peers", action="store_true",
                   help="also run PySPH's schemes on the cases it has examples of (Taylor-Green, "
                        "Poiseuille, hydrostatic tank, cavity) at the same resolutions, as rows "
                        "of the same tables and points of the same plots, and say whether a "
                        "point of ours beats each one's best (needs PySPH and a source "
                        "checkout; docs/peers.md; minutes with --quick, hours with --full)")
    v.add_argument("--peer-timeout", type=_positive, metavar="S",
                   help="--peers: wall-clock seconds allowed per PySPH run, its compilation "
                        "included; a run that takes longer is a row saying so (default 3600)")
    _add_benchmarks_dir(v, "the PySPH driver (--peers)")


class _Terminated(Exception):
    """SIGTERM arrived (a job scheduler's stop, `kill`)."""


def _on_sigterm(signum, frame):
    from .output import raise_or_hold

    raise_or_hold(_Terminated())  # (not within a file's write)


def _on_sigint(signum, frame):
    from .output import raise_or_hold

    raise_or_hold(KeyboardInterrupt())


def main(argv: list[str] | None = None) -> int:
    """The command line: an exit code (0 done, 2 bad input, 3 unstable, 130 on
    Ctrl+C, 143 on SIGTERM; both of those stop between steps, with every file
    written so far whole)."""
    import signal
    import threading

    args = _parser().parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = (signal.signal(signal.SIGTERM, _on_sigterm),
                    signal.signal(signal.SIGINT, _on_sigint))
    try:
        return _main(args, argv)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous[0])
            signal.signal(signal.SIGINT, previous[1])


def _main(args, argv: list[str] | None) -> int:
    from .scene import SceneError
    from .simulation import InstabilityError

    if isinstance(getattr(args, "scene", None), str):
        args.scene = _bundled(args.scene)
    try:
        if args.command == "run":
            return _run(args)
        if args.command == "view":
            return _view(args)
        if args.command == "record":
            return _record(args)
        if args.command == "schema":
            return _schema()
        if args.command == "check":
            return _check(args)
        if args.command == "bench":
            if args.surface_tension and (args.suite or args.draw or args.guard_cost):
                print("error: --surface-tension applies to the plain dam-break timing only, "
                      "not to --suite, --draw or --guard-cost", file=sys.stderr)
                return EXIT_BAD_INPUT
            if args.suite:
                from .bench_suite import main as suite_main

                args.method_given = "--method" in (argv if argv is not None else sys.argv)
                return suite_main(args)
            from .bench import main as bench_main

            return bench_main(args)
        if args.command == "stress":
            from .stress import main as stress_main

            return stress_main(args)
        if args.command == "validate":
            from .validation.runner import main as validate_main

            return validate_main(args)
        if args.command == "sweep":
            from .sweep import main as sweep_main

            return sweep_main(args)
        if args.command == "dataset":
            from .dataset import main as dataset_main

            return dataset_main(args)
        if args.command == "fuzz":
            from .fuzz import main as fuzz_main

            return fuzz_main(args)
    except SceneError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except InstabilityError as e:
        print(f"error: the simulation became unstable: {e}", file=sys.stderr)
        return EXIT_UNSTABLE
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130
    except _Terminated:
        print("terminated (SIGTERM)", file=sys.stderr)
        return 143
    except OSError as e:  # a full disk, a folder that cannot be written, ...
        where = f": {e.filename}" if e.filename else ""
        print(f"error: {e.strerror or e}{where} (the outputs written before it are complete; "
              "an output being written is left out)", file=sys.stderr)
        return EXIT_BAD_INPUT
    return 0


def _bundled(path: str) -> str:
    """A scene under scenes/ that is not in this folder (sphfluid installed from a
    wheel, the command run outside a checkout): the copy the package holds, said
    on stderr. Any other path as given."""
    given = Path(path)
    if given.exists() or given.is_absolute() or not given.parts or given.parts[0] != "scenes":
        return path
    packaged = Path(__file__).resolve().parent.joinpath(*given.parts)
    if not packaged.is_file():
        return path
    print(f"({path} is not in this folder: the copy installed with sphfluid, {packaged})",
          file=sys.stderr)
    return str(packaged)


def _run(args) -> int:
    """`sphfluid run`: set up, run to the end writing frames, print the summary."""
    from .scene import load_scene
    from .simulation import InstabilityError, Simulation

    scene = load_scene(args.scene)
    refused = _start_check(args, scene)
    if refused is not None:
        return refused
    duration = args.duration if args.duration is not None else scene.duration
    refused = _prepare_run(args, scene, duration)
    if refused is not None:
        return refused
    log = None
    if args.log is not None:
        from .runlog import RunLog

        try:  # a resumed run goes on in the log of the run it continues
            log = RunLog(args.log, append=args.resume is not None)
        except OSError as e:
            print(f"error: --log: cannot write {args.log}: {e.strerror or e}", file=sys.stderr)
            return EXIT_BAD_INPUT
    try:
        sim = Simulation(scene, threads=args.threads)
        if args.resume is not None:
            refused = _resume(args, sim, duration)
            if refused is not None:
                return refused
        print(_run_header(args, sim, duration), file=sys.stderr)
        if scene.probes is not None and args.out is None:
            print("note: the scene's probes are written to DIR/probes.csv with --out DIR only",
                  file=sys.stderr)
        run = _Run(args, sim, duration, log)
        try:
            run.to_end()
        except InstabilityError as e:
            print(f"error: the simulation became unstable: {e}", file=sys.stderr)
            print(sim.instability_advice(e), file=sys.stderr)
            return EXIT_UNSTABLE
    finally:
        if log is not None:
            log.close()
    _print_summary(run)
    return 0


def _start_check(args, scene) -> int | None:
    """The scene check (sphfluid check, without the schema) at the start of run and
    view: its findings on stderr; an exit code if one is an error, else None."""
    if args.no_check:
        return None
    from .check import check_scene

    try:
        raw = json.loads(Path(args.scene).read_text(encoding="utf-8"))  # to name the walls
    except (OSError, ValueError):
        raw = None
    report = check_scene(scene, raw)
    for f in report.findings:
        print(f, file=sys.stderr)
    if report.errors:
        print(f"error: {args.scene}: the scene check found {len(report.errors)} error(s) "
              "(sphfluid check); fix the scene, or pass --no-check to run it anyway",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    return None


def _resume(args, sim, duration: float) -> int | None:
    """Continue sim from --resume: None, or an exit code after saying why not."""
    from .checkpoint import CheckpointError

    try:
        sim.load_state(args.resume)
    except CheckpointError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    if sim.time >= duration * (1 - 1e-12):
        print(f"error: {args.resume}: the checkpoint is at t = {sim.time:.6g} s, at or past the "
              f"end of the run (t = {duration:g} s); pass a longer --duration", file=sys.stderr)
        return EXIT_BAD_INPUT
    return None


def _prepare_run(args, scene, duration: float | None) -> int | None:
    """Refuse a run without a duration, with --every, --surface or --format but no --out, or with
    --format vtk but no VTK writer installed, and make --out with the scene as run in
    it: an exit code after saying why not, or None."""
    if duration is None:
        print(f"error: {args.scene}: the scene has no 'duration'; pass --duration T",
              file=sys.stderr)
        return EXIT_BAD_INPUT
    for given, option in ((args.every, "--every"), (args.checkpoint_every, "--checkpoint-every"),
                          (args.surface or None, "--surface")):
        if given is not None and args.out is None:
            print(f"error: {option} needs --out DIR", file=sys.stderr)
            return EXIT_BAD_INPUT
    fmt = getattr(args, "format", None)
    if fmt is not None and args.out is None:
        print("error: --format needs --out DIR", file=sys.stderr)
        return EXIT_BAD_INPUT
    if fmt == "vtk":
        from .output import WriterMissingError, require_vtk_writer

        try:
            require_vtk_writer()
        except WriterMissingError as e:
            print(f"error: {e}", file=sys.stderr)
            return EXIT_BAD_INPUT
    if args.out is not None:
        try:
            args.out.mkdir(parents=True, exist_ok=True)
            (args.out / "scene.json").write_text(json.dumps(scene.to_dict(), indent=2))
        except OSError as e:
            print(f"error: cannot write to {args.out}: {e}", file=sys.stderr)
            return EXIT_BAD_INPUT
    return None


def _run_header(args, sim, duration: float) -> str:
    """What will run: particles, walls, method, steps, threads."""
    scene = sim.scene
    step_text = ("adaptive dt (cfl " + f"{scene.cfl:g})" if sim.adaptive
                 else f"dt {scene.time_step:g} s, "
                      f"{math.ceil(duration / scene.time_step - 1e-9):,} steps")
    precision = ""
    stats = sim.stats()
    if scene.pair_precision != "double":  # say which ran: float needs the cell clusters
        precision = (" (pair forces in float)" if stats["pair_precision"] == "float" else
                     " (pair forces in double: float runs without surface tension and periodic "
                     "axes, in AVX-512 builds)")
    if scene.pressure_kernel == "quintic" and stats["pressure_kernel"] != "quintic":
        precision += " (pressure on the Wendland kernel: the flow is shifted, W31 does not act)"
    if sim.time > 0:  # resumed
        step_text += f", resuming at t = {sim.time:.6g} s (step {sim.step_count:,})"
    return (f"{scene.name or Path(args.scene).name}: {sim.n_particles:,} particles, "
            f"{len(scene.walls)} walls, method {scene.method}{precision}, {step_text} to "
            f"t = {duration:g} s, "
            f"{sim.threads} thread(s)"
            + (f" ({sim.threads_in_use} in use below 1,000 particles)"
               if sim.threads_in_use != sim.threads else ""))


class _Run:
    """The run loop of `sphfluid run`: it lands on every frame time, checkpoint
    time and the end (the times that shape an adaptive run's path, so a run
    resumed from a checkpoint with the same options continues bit for bit),
    samples the density's extremes and draws progress every CHUNK steps between
    them, writes the frames, checkpoints and log lines, warns of retried steps
    and, on a blow-up, saves the last good state.

    The log (a RunLog, or None) gets a line at the start and at every landing;
    without frames, whose times are the run's output times, also at the first
    sample at or past each hundredth of the run. It adds no landing, so a run
    logs without changing its path."""

    CHUNK = 25  # steps between progress and density samples
    LONG_RUN = 600.0  # s: under --quiet, a run expected to take longer gets a note
    NOTE_AFTER = 0.5  # s: the least wall time its estimate is timed over
    LOG_PARTS = 100  # without --out, log at least every 1/LOG_PARTS of the run (at samples)

    def __init__(self, args, sim, duration: float, log=None):
        from .progress import Progress

        self.sim = sim
        self.out: Path | None = args.out
        self.scene_path = args.scene
        self.duration = duration
        start = sim.time  # 0, or a checkpoint's time
        every = args.every if args.every is not None else 1.0 / 30.0

        def multiples(step: float | None) -> dict[float, int]:  # time -> k, after start
            if step is None:
                return {}
            return {t: k for k in range(1, int(duration / step + 1e-9) + 1)
                    if (t := round(step * k, 12)) > start * (1 + 1e-12)}

        self.frame_times = multiples(every) if self.out else {}
        self.checkpoint_times = set(multiples(args.checkpoint_every))
        if args.checkpoint_every is not None:
            self.checkpoint_times.add(duration)
        self.bar = None if args.quiet else Progress(duration, start, sim.step_count)
        # under --quiet no bar shows the time left: a run that looks long at a
        # sample gets one line saying how long (note_length)
        self.noted = self.bar is not None
        self.start, self.first_step = start, sim.step_count
        self.started = time.perf_counter()  # (to_end sets it again as it begins)
        self.checkpoint_time: float | None = None  # of the last checkpoint written
        self.frames = 0
        self.writer = None
        if self.out:
            from .output import frame_writer

            self.writer = frame_writer(getattr(args, "format", None) or "npz", self.out, sim,
                                       surface=getattr(args, "surface", False))
            if start > 0 and self.frame_times:  # resumed: the frames before are there
                self.writer.resume(min(self.frame_times.values()))
        self.max_err, self.max_comp = sim.density_extremes()
        self.particle_steps = 0
        self.retries_seen = 0
        self.wall = 0.0  # s
        self.log = log
        # without frames: a log line at the first sample at or past each multiple of this
        self.log_every = None if self.out else duration / self.LOG_PARTS
        self.next_log = start
        if log is not None:
            log.write_metadata(sim)
        # the scene's probes: a row of DIR/probes.csv at the first sample at or past
        # each multiple of probes.every (default: the frame interval); no landing added
        self.probes = None
        if self.out and sim.scene.probes is not None:
            from .probes import ProbeWriter

            probes = sim.scene.probes
            self.probes = ProbeWriter(self.out / "probes.csv", sim, probes,
                                      probes.every or every, duration)

    def to_end(self) -> None:
        self.started = time.perf_counter()
        if self.out and self.start == 0:
            self.write_frame()
        self.write_log()
        self.write_probes()
        for target in sorted({*self.frame_times, *self.checkpoint_times, self.duration}):
            self.advance_to(target)
            if target in self.frame_times:
                self.write_frame()
            if target in self.checkpoint_times:
                self.sim.save_state(self.out / "checkpoint.npz")
                self.checkpoint_time = self.sim.time
            self.write_log()
        if self.bar:
            self.bar.close()
        if self.probes is not None:
            self.probes.close()
        self.wall = time.perf_counter() - self.started

    def advance_to(self, target: float) -> None:
        """To target, sampling every CHUNK steps."""
        from .simulation import InstabilityError

        sim = self.sim
        while True:
            n_before = sim.n_particles
            try:
                steps = sim.advance_to(target, max_steps=self.CHUNK)
            except InstabilityError as e:
                if self.bar:
                    self.bar.close()
                if self.log is not None:  # the last good state, and what tripped
                    self.write_log(sim.stats(), instability=str(e))
                self.save_last_good_state()
                raise
            self.warn_of_retries()
            self.particle_steps += steps * n_before
            err, comp = sim.density_extremes()  # (not all of stats(): a sample is often)
            self.max_err, self.max_comp = max(self.max_err, err), max(self.max_comp, comp)
            if self.bar:
                self.bar.update(sim.time, sim)
            self.write_probes()
            self.note_length()
            if (self.log_every is not None and self.log is not None
                    and sim.time >= self.next_log and not sim._reached(target)):
                self.write_log()  # (a landing writes its own line)
            if steps < self.CHUNK:
                return

    def note_length(self) -> None:
        """Under --quiet, one line on stderr the first time the time left, at the
        pace so far (timed over NOTE_AFTER s at least), is over LONG_RUN: no bar
        says so. (At the samples only: a note changes nothing of the run.)"""
        if self.noted:
            return
        sim, now = self.sim, time.perf_counter()
        wall, done = now - self.started, sim.time - self.start
        if wall < self.NOTE_AFTER or done <= 0:
            return
        left = wall / done * (self.duration - sim.time)
        if left < self.LONG_RUN:
            return
        from .check import _duration

        self.noted = True
        print(f"note: at its pace so far this run ends in about {_duration(left)} "
              f"(t = {sim.time:.4g} of {self.duration:g} s after {_duration(now - self.started)})"
              f"; Ctrl+C stops it" + ("" if self.checkpoint_times else
                                      ", --checkpoint-every T lets a stopped run resume"),
              file=sys.stderr)

    def write_log(self, stats: dict | None = None, **extra) -> None:
        """A line of the log (if any) for the current state (or stats)."""
        if self.log is None:
            return
        from .runlog import health

        sim = self.sim
        self.log.write({**health(sim, stats),
                        "wall_time": time.perf_counter() - self.started, **extra})
        if self.log_every is not None:  # the next multiple of log_every past now
            k = math.floor(sim.time / self.log_every * (1 + 1e-12)) + 1
            self.next_log = k * self.log_every * (1 - 1e-12)

    def write_probes(self) -> None:
        """A row of probes.csv, if this sample is the first at or past a probe time."""
        if self.probes is not None and self.probes.due(self.sim.time):
            self.probes.write(self.sim)

    def write_frame(self) -> None:
        self.writer.write(self.sim)
        self.frames += 1

    def warn_of_retries(self) -> None:
        """The retries since the last call (the log keeps the latest)."""
        sim = self.sim
        if sim.retried_steps > self.retries_seen:
            new = sim.retried_steps - self.retries_seen
            for line in sim.retry_log[-min(new, 100):]:
                print(f"warning: {line}", file=sys.stderr)
            self.retries_seen = sim.retried_steps

    def save_last_good_state(self) -> None:
        sim = self.sim
        saved = (self.out / "last_good_state.npz" if self.out
                 else Path(f"{Path(self.scene_path).stem}.last_good_state.npz"))
        try:
            sim.save_state(saved)
            print(f"the last good state (t = {sim.time:.6g} s, step {sim.step_count}) is "
                  f"saved in {saved}", file=sys.stderr)
        except OSError as e:
            print(f"could not save the last good state: {e}", file=sys.stderr)


def _density_note(scene) -> str:
    """Why the run summary's density error can be large where nothing is wrong."""
    if scene.density != "continuity" or scene.method != "wcsph":
        return "; at a free surface the summed density falls short"
    if scene.free_surface == "pressure_floor":  # W26b
        return "; in spray and at free surfaces the carried density stretches, at no tension"
    return ""


def _print_summary(run: _Run) -> None:
    sim, wall = run.sim, run.wall
    done = sim.step_count - run.first_step
    st = sim.stats()
    print(f"steps               {done:,}" + (f" (from step {run.first_step:,})" if run.start else ""))
    print(f"simulated time      {sim.time - run.start:.4f} s"
          + (f" (from t = {run.start:.6g} s to {sim.time:.6g} s)" if run.start else ""))
    print(f"wall time           {wall:.2f} s")
    if sim.adaptive:
        print(f"mean dt             {(sim.time - run.start) / max(done, 1):.3g} s "
              f"(last {sim.dt:.3g} s, "
              f"limited by {sim.dt_limit})")
    print(f"steps/s             {done / max(wall, 1e-9):,.0f}")
    print(f"particle-steps/s    {run.particle_steps / max(wall, 1e-9):,.0f}")
    print(f"particles           {sim.n_particles:,}")
    print(f"removed particles   {sim.removed_particles:,} (left the domain)")
    scene = sim.scene
    if scene.method == "dfsph":
        its = st["solve_iterations"]
        each = (f", {1e3 * sim._solver.phase_seconds()['solve'] / its:.3g} ms each" if its
                else "")
        print(f"pressure solves     {its:,} iterations ({its / max(done, 1):.1f} a step{each}; "
              f"last step {st['solve_density_iterations']} + "
              f"{st['solve_divergence_iterations']}); "
              f"{st['solve_unconverged']:,} stopped at max_iterations")
    if scene.emitters or scene.sinks or scene.inlets or scene.outlets:
        b = sim.balance
        print(f"particle balance    {b['placed']:,} placed + {b['in']:,} in - {b['out']:,} out - "
              f"{b['sunk']:,} sunk - {b['lost']:,} lost = {b['now']:,} now")
    print(f"max compression     {run.max_comp:.4f} (largest rho/rho0 - 1 of the sampled states, "
          "0 if none is above rho0)")
    print(f"max density error   {run.max_err:.4f} (largest |rho/rho0 - 1| of the same "
          f"states{_density_note(sim.scene)})")
    print(f"max speed           {st['max_speed']:.3f} m/s at the end")
    if sim.retried_steps:
        print(f"retried steps       {sim.retried_steps} (with halved time steps)")
    if run.out:
        print(f"frames              {run.frames} in {run.out}{os.sep}")
    if run.probes is not None:
        print(f"probes              {run.probes.rows} rows in {run.probes.path}")
    if run.checkpoint_time is not None:
        print(f"checkpoint          {run.out / 'checkpoint.npz'} (t = {run.checkpoint_time:.6g} s; "
              "sphfluid run SCENE --resume it)")


def _check(args) -> int:
    """`sphfluid check`: the loader (the JSON Schema, then what it cannot say), then
    the physical checks."""
    from .check import check_scene
    from .scene import load_scene

    scene = load_scene(args.scene)  # a SceneError: its problems, exit 2 (main)
    raw = json.loads(Path(args.scene).read_text(encoding="utf-8"))
    report = check_scene(scene, raw)
    findings = list(report.findings)
    estimate = None
    if not any(f.level == "error" for f in findings):
        from .check import run_time

        estimate, blow_up = run_time(scene, threads=args.threads)
        findings += [blow_up] if blow_up else []
    for f in findings:
        print(f)
    for line in report.info + ([estimate] if estimate else []):
        print(line)
    errors = sum(f.level == "error" for f in findings)
    warnings = len(findings) - errors
    print(f"{args.scene}: {errors} error(s), {warnings} warning(s)")
    return EXIT_BAD_INPUT if errors else 0


def _schema() -> int:
    """`sphfluid schema`: the scene format's JSON Schema, as shipped, on stdout."""
    from importlib import resources

    sys.stdout.write(resources.files("sphfluid").joinpath("scene.schema.json").read_text(
        encoding="utf-8"))
    return 0


def _size(text: str) -> tuple[int, int] | None:
    """WxH in pixels, or None after printing why not."""
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        w = h = 0
    if w >= 100 and h >= 100:
        return (w, h)
    print(f"error: --size: expected WxH of at least 100x100 pixels, got {text!r}",
          file=sys.stderr)
    return None


def _view(args) -> int:
    from .scene import load_scene
    from .viewer import view

    size = _size(args.size)
    if size is None:
        return EXIT_BAD_INPUT
    scene = load_scene(args.scene)
    refused = _start_check(args, scene)
    if refused is not None:
        return refused
    return view(scene, frames=args.frames, screenshot=args.screenshot,
                steps_per_frame=args.steps_per_frame, size=size, threads=args.threads,
                mode=args.mode)


def _record(args) -> int:
    from .progress import Progress
    from .viewer import record

    size = _size(args.size)
    if size is None:
        return EXIT_BAD_INPUT
    bar = None

    def progress(done, total, sim):
        nonlocal bar
        if args.quiet:
            return
        if bar is None:  # frames at k / fps, k = 0 .. total - 1
            bar = Progress((total - 1) / args.fps)
        bar.update(sim.time, sim)

    try:
        n = record(args.scene, args.out, duration=args.duration, fps=args.fps, mode=args.mode,
                   size=size, threads=args.threads, progress=progress)
    except ValueError as e:
        print(f"error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    finally:
        if bar is not None:
            bar.close()
    print(f"wrote {n} frames to {args.out}")
    return 0
