"""Build and run the plain reference loop (reference_loop.cpp beside this file).

Reads reference_loop.cpp and the compiler ($CXX, else c++ or g++); writes the
binary into a cache folder under the temporary directory, named by the hash of
the source, the compiler and the flags (built once per change), and the loop's
input files. `sphfluid bench` runs it next to ours on the same dam break;
tests/test_reference_loop.py checks its physics against a brute-force sum.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

SOURCE = Path(__file__).resolve().parent / "reference_loop.cpp"
FLAGS = ("-O3", "-march=native", "-fopenmp", "-std=c++17")
CACHE = Path(tempfile.gettempdir()) / "sphfluid-reference-loop"
KEYS = ("mass", "h", "k", "rho0", "eta", "gx", "gy", "tank", "dt", "warmup", "steps", "threads")


class ReferenceLoopError(RuntimeError):
    """No compiler, or the loop did not build or run."""


def compiler() -> str:
    """$CXX, else the first of c++ and g++ on the PATH."""
    found = os.environ.get("CXX") or shutil.which("c++") or shutil.which("g++")
    if not found:
        raise ReferenceLoopError("no C++ compiler ($CXX, c++ or g++)")
    return found


def build(cache: Path = CACHE) -> Path:
    """The loop's binary, compiled if the source, compiler or flags changed."""
    cxx = compiler()
    key = hashlib.sha256("\0".join([SOURCE.read_text(), cxx, *FLAGS]).encode()).hexdigest()
    binary = cache / f"reference_loop-{key[:16]}"
    if binary.is_file():
        return binary
    cache.mkdir(parents=True, exist_ok=True)
    partial = binary.with_name(f"{binary.name}.{os.getpid()}.partial")
    try:
        done = subprocess.run([cxx, *FLAGS, str(SOURCE), "-o", str(partial)], check=False,
                              capture_output=True, text=True, timeout=300)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ReferenceLoopError(f"{cxx} failed: {exc}") from exc
    if done.returncode != 0:
        lines = [line for line in done.stderr.splitlines() if line.strip()] or ["no message"]
        raise ReferenceLoopError(f"{cxx} {' '.join(FLAGS)} failed: {lines[0][:200]}")
    os.replace(partial, binary)  # whole, even when two builds race
    return binary


def write_input(path: Path, positions: np.ndarray, velocities: np.ndarray, **params) -> Path:
    """The loop's input file: the parameters of KEYS (h in m, dt in s, tank: the
    right wall's x in m, 0 for no walls, ...) and the particles (n, 2) arrays."""
    missing = [k for k in KEYS if k not in params]
    if missing:
        raise ValueError(f"missing parameters {missing}")
    rows = np.column_stack([positions, velocities])
    with open(path, "w", encoding="ascii") as f:
        f.write("sphfluid-reference-loop/1\n")
        f.write(f"n {len(rows)}\n")
        f.writelines(f"{k} {float(params[k])!r}\n" for k in KEYS)
        f.write("particles\n")
        np.savetxt(f, rows, fmt="%.17g")
    return path


def run(binary: Path, input_file: Path, timeout: float = 3600.0) -> float:
    """Run the loop on an input file: its steps per second (timed steps only)."""
    out = _call([str(binary), str(input_file)], timeout)
    for line in out.splitlines():
        words = line.split()
        if words[:1] == ["steps_per_s"]:
            return float(words[1])
    raise ReferenceLoopError(f"no steps_per_s in its output: {out[:200]!r}")


def evaluate(binary: Path, positions: np.ndarray, velocities: np.ndarray,
             **params) -> tuple[np.ndarray, np.ndarray]:
    """One evaluation at the given state, no step: densities (n,) and accelerations
    (n, 2) in the order of the particles given."""
    params = {"warmup": 0, "steps": 0, "dt": 0.0, "threads": 1, **params}
    with tempfile.TemporaryDirectory(prefix="sphfluid-reference-loop-") as tmp:
        source = write_input(Path(tmp) / "input.txt", positions, velocities, **params)
        dump = Path(tmp) / "dump.txt"
        _call([str(binary), str(source), "--dump", str(dump)], 600.0)
        values = np.loadtxt(dump, ndmin=2)
    return values[:, 0], values[:, 1:3]


def _call(command: list[str], timeout: float) -> str:
    try:
        done = subprocess.run(command, check=False, capture_output=True, text=True,
                              timeout=timeout)
    except (OSError, subprocess.TimeoutExpired) as exc:
        raise ReferenceLoopError(str(exc)) from exc
    if done.returncode != 0:
        raise ReferenceLoopError(f"exit code {done.returncode}: {done.stderr.strip()[:200]}")
    return done.stdout
