"""``sphfluid fuzz``: broken scenes and bad API calls, each expected to end cleanly.

Each case is made from (seed, index) alone, so any case can be made again:

- a *scene* case mutates a bundled scene one to three times: a value, a whole
  section or a key replaced by a wrong type, NaN, infinity, a huge, tiny or
  negative number, null, deep nesting, a degenerate wall or region; it is then
  loaded, checked (``sphfluid check``'s checks) and, if it loads, stepped;
- an *API* case makes a small Simulation and calls its methods with bad
  arguments (counts, times, thread counts, arrays of the wrong shape or with
  NaN, ids, walls 1e10 m long or of zero length), then steps it.

Every outcome is one of: ``error`` (refused with a message: SceneError,
ValueError, TypeError, IndexError), ``ran``, ``blow-up`` (InstabilityError),
``big`` (a scene too large to step here: not run), or *bad*: ``traceback`` (any
other exception, or pybind11's own argument error), ``hang`` (no answer within
the time limit), ``crash`` (the process died), ``memory`` (over the memory
limit). The cases run in a worker process, restarted after a bad one, under a
memory limit; bad must be zero.
"""
from __future__ import annotations

import copy
import json
import math
import os
import random
import select
import subprocess
import sys
import time
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

OUTCOMES = ("error", "ran", "blow-up", "big", "traceback", "hang", "crash", "memory")
BAD = ("traceback", "hang", "crash", "memory")
# Messages of errors raised by pybind11, numpy or Python itself rather than by a
# check of ours: a user gets no clear word from them, so they count as tracebacks.
_UNCLEAR = ("incompatible function arguments", "is not iterable", "cannot reshape",
            "not supported between", "can't multiply sequence", "inhomogeneous",
            "argument must be a string or a real number", "object is not subscriptable",
            "unhashable type", "has no len()", "could not convert")
STEPS = 20  # steps a loaded scene takes
MAX_PARTICLES = 200_000  # larger scenes are loaded and checked, not stepped ("big")
MEMORY_LIMIT = 6 * 2**30  # bytes of address space for the worker
CASE_TIMEOUT = 60.0  # s for one case

# Values that replace a scene's values: types, non-finite, huge, tiny, degenerate.
_VALUES: list[Any] = [
    None, [], {}, [[]], 0, -1, 1, 0.5, 1e308, 0.9e308, 1e-300, 5e-324, 10**400, 2**64,
    float("nan"), float("inf"), -float("inf"), "x", "", "auto", True, False, [1], [1, 2, 3],
    [0, 0], [1e15, 1e15], [1e300, -1e300], [float("nan"), 0], [[0, 0], [1e-320, 0]],
    [[0, 0], [0, 0]], {"shape": []}, {"shape": {}}, {"shape": "circle"},
    {"polyline": []}, {"polyline": [[0, 0]] * 3, "closed": True}, "seed", "wcsph",
    [[0, 0], [1, 1]], 1e200, 1e10, 1e-12, [[0, 0], [1, 0], [0, 1], [1, 1]],
    {"points": [{"name": "p", "at": [1e9, 0]}]}, {"walls": [{"name": "w", "segments": [10**9]}]},
]
_FACTORS = (0, -1, 1e-300, 1e-9, 1e-3, 0.1, 0.5, 2, 10, 1e3, 1e9, 1e300, float("inf"),
            float("nan"))
_SECTIONS = ("solver", "probes", "fluid", "walls", "domain", "resolution", "fluid_regions",
             "gravity", "duration", "name", "format")


@dataclass
class Result:
    kind: str  # "scene" or "api"
    index: int
    outcome: str
    detail: str  # the exception's type and message, or what was run


# --------------------------------------------------------------------------- cases

def scenes_in(folder: Path) -> list[dict]:
    """The scenes of a folder (the repository's scenes/): the cases' starting points."""
    scenes = [json.loads(p.read_text(encoding="utf-8")) for p in sorted(folder.glob("*.json"))]
    if not scenes:
        raise FileNotFoundError(f"no scene (*.json) in {folder}")
    return scenes


def scene_case(rng: random.Random, bases: list[dict]) -> Any:
    d: Any = copy.deepcopy(rng.choice(bases))
    for _ in range(rng.choice((1, 1, 1, 2, 3))):
        value = copy.deepcopy(rng.choice(_VALUES))
        roll = rng.random()
        if roll < 0.08 and isinstance(d, dict):
            d[rng.choice(_SECTIONS)] = value
        elif roll < 0.1:
            d = _nest(rng.randint(50, 2000))
        else:
            place = rng.choice(list(_paths(d)))
            old = _at(d, place)
            if isinstance(old, (int, float)) and not isinstance(old, bool) and rng.random() < 0.6:
                factor = rng.choice(_FACTORS)  # a number stays a number, out of range
                value = old * factor if abs(old) < 1e300 else factor
            d = _set(d, place, value)
    return d


def _nest(depth: int) -> Any:
    value: Any = 0
    for _ in range(depth):
        value = [value]
    return {"format": "sphfluid-scene/1", "name": value}


def _paths(d: Any, path: tuple = ()):
    """The paths into d, down to 12 levels."""
    yield path
    items = d.items() if isinstance(d, dict) else enumerate(d) if isinstance(d, list) else ()
    if len(path) < 12:
        for k, v in items:
            yield from _paths(v, path + (k,))


def _at(d: Any, path: tuple) -> Any:
    for k in path:
        d = d[k]
    return d


def _set(d: Any, path: tuple, value: Any) -> Any:
    if not path:
        return value
    node = d
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    return d


_API_ARGS: list[Any] = [0, -1, 1, 3, 2**31, 2**64, 1.5, "3", None, float("nan"), float("inf"),
                        1e300, -1e300, [], [[0.5, 0.5]], [[float("nan"), 0.5]], [[1, 2, 3]],
                        [[0.5, 0.5], [0.6, 0.5]], [[[0, 0], [1e10, 0]]], [[[0, 0], [0, 0]]]]
_API_CALLS = ("step", "advance_to", "run", "threads", "set_state", "add_particles",
              "set_walls", "add_wall", "remove_wall", "ids")


def api_case(rng: random.Random) -> list[tuple[str, Any]]:
    return [(rng.choice(_API_CALLS), rng.choice(_API_ARGS)) for _ in range(rng.randint(1, 3))]


# --------------------------------------------------------------------------- one case

def run_case(kind: str, index: int, seed: int, scenes: list[dict]) -> Result:
    """Make case (seed, index) of `kind` (from `scenes`) and run it here, catching
    what it raises."""
    from .scene import SceneError
    from .simulation import InstabilityError

    rng = random.Random(f"{seed}/{kind}/{index}")
    try:
        if kind in _SELF_TESTS:  # the classification's own tests
            _SELF_TESTS[kind]()
        if kind == "scene":  # odd cases through a file: JSON text and its parser
            detail = _run_scene(scene_case(rng, scenes), as_file=index % 2 == 1)
        else:
            detail = _run_api(api_case(rng))
        outcome = "big" if detail.startswith("big") else "ran"
    except InstabilityError as e:
        outcome, detail = "blow-up", _first_line(e)
    except (SceneError, ValueError, IndexError, TypeError) as e:
        unclear = any(m in str(e) for m in _UNCLEAR)
        outcome = "traceback" if unclear else "error"
        detail = f"{type(e).__name__}: {_first_line(e)}"
    except MemoryError as e:
        outcome, detail = "memory", f"MemoryError: {e}"
    except BaseException as e:  # noqa: BLE001  (the point is to catch everything)
        import traceback

        outcome = "traceback"
        detail = "".join(traceback.format_exception(type(e), e, e.__traceback__))[-2000:]
    return Result(kind, index, outcome, detail)


def _raise() -> None:
    raise KeyError("a bug")


# Cases that misbehave on purpose, so tests can see each bad outcome classified.
_SELF_TESTS = {"_abort": os.abort, "_hang": lambda: time.sleep(1e6), "_raise": _raise,
               "_memory": lambda: bytearray(2 * MEMORY_LIMIT)}


def _first_line(e: BaseException) -> str:
    return (str(e).splitlines() or [""])[0][:300]


def _run_scene(d: Any, as_file: bool = False) -> str:
    import tempfile

    from .check import check_scene
    from .scene import load_scene
    from .simulation import Simulation

    if as_file:
        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "case.json"
            try:
                path.write_text(json.dumps(d), encoding="utf-8")
            except (ValueError, RecursionError):  # too deep or too long for Python's JSON
                path.write_text("[" * 100_000 + "]" * 100_000, encoding="utf-8")
            scene = load_scene(path)
    else:
        scene = load_scene(d)
    report = check_scene(scene, d)
    errors = [str(f) for f in report.findings if f.level == "error"]
    if errors:
        raise ValueError(errors[0])
    if scene.estimated_particles() > MAX_PARTICLES:
        return f"big: {scene.estimated_particles():,} particles"
    sim = Simulation(scene, threads=1)
    sim.step(STEPS)
    return f"{sim.n_particles} particles, {STEPS} steps"


def _run_api(calls: list[tuple[str, Any]]) -> str:
    import numpy as np

    from .simulation import Simulation

    scene = {"format": "sphfluid-scene/1", "domain": {"min": [-0.1, -0.1], "max": [1.1, 1.1]},
             "fluid": {"rest_density": 1000.0, "gas_constant": 100.0, "viscosity": 1.0},
             "resolution": {"spacing": 0.05},
             "fluid_regions": [{"shape": "rectangle", "min": [0, 0], "max": [0.5, 0.5]}],
             "walls": [{"polyline": [[0, 1], [0, 0], [1, 0], [1, 1]]}],
             "solver": {"method": "seed", "time_step": 0.001}}
    sim = Simulation(scene, threads=1)
    for name, arg in calls:
        # Counts and durations that are valid but long (step(2**31) takes 2**31
        # steps, as asked) are cut to a few steps: a bad case is one that fails.
        long = isinstance(arg, (int, float)) and not isinstance(arg, bool) and abs(arg) > 0.05
        if name == "step":
            sim.step(min(arg, 50) if long and isinstance(arg, int) else arg)
        elif name == "advance_to":
            sim.advance_to(arg, max_steps=50)
        elif name == "run":
            sim.run(math.copysign(0.05, arg) if long and math.isfinite(arg) else arg, every=arg)
        elif name == "threads":
            sim.threads = arg
        elif name == "set_state":
            arr = np.asarray(arg) if isinstance(arg, list) else arg
            sim.set_state(arr, arr)
        elif name == "add_particles":
            sim.add_particles(arg)
        elif name == "set_walls":
            sim.set_walls(arg)
        elif name == "add_wall":
            sim.add_wall(arg, (0.3, 0.3))
        elif name == "remove_wall":
            sim.remove_wall(arg)
        else:
            sim.set_state(sim.positions, sim.velocities, ids=arg)
    sim.step(5)
    return f"{calls!r}"[:300]


# --------------------------------------------------------------------------- the worker

def memory_limited() -> bool:
    """Whether the worker runs under MEMORY_LIMIT: where the OS has the limit, and
    not under AddressSanitizer (whose shadow memory reserves terabytes)."""
    from . import _core

    try:
        import resource  # noqa: F401
    except ImportError:
        return False
    return "address" not in _core.build_info.get("sanitize", "")


def worker(folder: str) -> None:
    """Reads "kind index seed" lines on stdin, writes one JSON result per line;
    the scene cases start from the scenes in folder."""
    if memory_limited():
        import resource

        resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    import warnings

    warnings.simplefilter("ignore")  # numpy's overflow warnings on absurd values
    scenes = scenes_in(Path(folder))
    for line in sys.stdin:
        kind, index, seed = line.split()
        r = run_case(kind, int(index), int(seed), scenes)
        sys.stdout.write(json.dumps(r.__dict__) + "\n")
        sys.stdout.flush()


class _Worker:
    def __init__(self, folder: Path) -> None:
        env = {**os.environ, "OMP_NUM_THREADS": "1", "OMP_WAIT_POLICY": "PASSIVE"}
        self.proc = subprocess.Popen(
            [sys.executable, "-c", "import sys; from sphfluid.fuzz import worker; "
             "worker(sys.argv[1])", str(folder)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            text=True, env=env)

    def run(self, kind: str, index: int, seed: int, timeout: float) -> Result:
        assert self.proc.stdin is not None and self.proc.stdout is not None
        try:
            self.proc.stdin.write(f"{kind} {index} {seed}\n")
            self.proc.stdin.flush()
        except BrokenPipeError:
            return Result(kind, index, "crash", self._death())
        ready, _, _ = select.select([self.proc.stdout], [], [], timeout)
        if not ready:
            self.close()
            return Result(kind, index, "hang", f"no answer in {timeout:g} s")
        line = self.proc.stdout.readline()
        if not line:
            return Result(kind, index, "crash", self._death())
        return Result(**json.loads(line))

    def _death(self) -> str:
        code = self.proc.wait()
        self.close()
        return f"the worker died (exit code {code}{', a signal' if code < 0 else ''})"

    def close(self) -> None:
        self.proc.kill()
        self.proc.wait()
        for pipe in (self.proc.stdin, self.proc.stdout):
            if pipe is not None:
                try:
                    pipe.close()
                except BrokenPipeError:
                    pass


def fuzz(cases: int, seed: int, folder: Path, timeout: float = CASE_TIMEOUT,
         log=None) -> list[Result]:
    """`cases` cases from `seed`, scene (from the scenes in folder) and API cases
    alternating, each in a worker process; log(result) after each."""
    scenes_in(folder)  # a missing folder: an error here, not a crash in the worker
    results = []
    w = _Worker(folder)
    try:
        for i in range(cases):
            kind = "scene" if i % 2 == 0 else "api"
            r = w.run(kind, i // 2, seed, timeout)
            results.append(r)
            if log is not None:
                log(r)
            if r.outcome in BAD:
                w.close()
                w = _Worker(folder)
    finally:
        w.close()
    return results


def case_json(index: int, seed: int, folder: Path) -> str:
    """Scene case (seed, index) as JSON text (NaN and infinities as Python writes them)."""
    rng = random.Random(f"{seed}/scene/{index}")
    return json.dumps(scene_case(rng, scenes_in(folder)), indent=1)


# --------------------------------------------------------------------------- the command

def main(args) -> int:
    """`sphfluid fuzz`: the cases, a table of outcomes, the bad ones; 1 if any is bad."""
    from .progress import Runs

    if args.case:
        kind, _, index = args.case.partition(":")
        r = run_case(kind, int(index), args.seed, scenes_in(args.scenes))
        if kind == "scene":
            print(case_json(int(index), args.seed, args.scenes))
        print(f"{r.kind} case {r.index} (seed {args.seed}): {r.outcome}\n{r.detail}")
        return 1 if r.outcome in BAD else 0
    start = time.perf_counter()
    with Runs(args.cases, what="cases") as runs:
        def log(r: Result) -> None:
            if r.outcome in BAD:
                runs.done(f"BAD {r.outcome}: {r.kind} case {r.index}: {r.detail.strip()}")
            elif args.verbose:
                runs.done(f"{r.kind:5s} {r.index:5d} {r.outcome:8s} {r.detail[:100]}")
            else:
                runs.advance()

        results = fuzz(args.cases, args.seed, args.scenes, args.timeout, log)
    counts = Counter((r.kind, r.outcome) for r in results)
    print(f"sphfluid fuzz --cases {args.cases} --seed {args.seed}: "
          f"{time.perf_counter() - start:.0f} s\n")
    print("| outcome | scene cases | API cases |\n|---|---|---|")
    for o in OUTCOMES:
        if counts[("scene", o)] or counts[("api", o)] or o in BAD:
            print(f"| {o}{' (bad)' if o in BAD else ''} | {counts[('scene', o)]} | "
                  f"{counts[('api', o)]} |")
    bad = [r for r in results if r.outcome in BAD]
    print(f"\nbad: {len(bad)}")
    for r in bad:
        print(f"  {r.kind}:{r.index} {r.outcome} (sphfluid fuzz --seed {args.seed} "
              f"--case {r.kind}:{r.index})")
    return 1 if bad else 0
