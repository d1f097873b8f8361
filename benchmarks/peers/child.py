"""What every peer driver shares: its configuration, the reports it prints, the
surge front and the step clock. Reads the configuration JSON file named on the
command line (written by peers.py); writes report lines on stdout, one each:

    @peer start  {"method", "version", "particles"}
    @peer sample {"t", "z", "steps", "wall"}   every sample_every s of simulated time
    @peer done   {"t", "steps", "wall"}

`steps` and `wall` count the timed steps so far, so a crash keeps what was reached.
Imports numpy only, so that a driver's own imports fail first and clearly.
"""
from __future__ import annotations

import json
import sys
import time

import numpy as np


def load_config(argv: list[str] | None = None) -> dict:
    """The configuration JSON file named by the first argument."""
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 1:
        raise SystemExit("usage: python DRIVER.py CONFIG.json (written by peers.py)")
    with open(args[0], encoding="utf-8") as f:
        return json.load(f)


class Reporter:
    """Prints the report lines of one run, and times and samples its steps."""

    def __init__(self, config: dict):
        self.config = config
        self.dx = config["spacing"]
        self.steps = 0
        self.wall = 0.0
        self.next_sample = config["sample_every"]
        self.started = time.perf_counter()

    def emit(self, kind: str, **fields) -> None:
        print(self.config["tag"], kind, json.dumps(fields), flush=True)

    def start(self, method: str, version: str, particles: int) -> None:
        """Report what runs; the clock starts with begin()."""
        self.emit("start", method=method, version=version, particles=int(particles))

    def begin(self) -> None:
        """Start the clock: call right before the first timed step."""
        self.started = time.perf_counter()

    def surge_front(self, pos: np.ndarray) -> float:
        """Rightmost particle with at least two others within 2 dx, plus dx/2."""
        if not np.all(np.isfinite(pos)):
            raise RuntimeError("non-finite particle positions")
        dx = self.dx
        order = np.argsort(pos[:, 0])[::-1]
        for i in order[:200]:
            if np.count_nonzero(((pos - pos[i]) ** 2).sum(1) < (2 * dx) ** 2) >= 3:
                return float(pos[i, 0] + dx / 2)
        return float(pos[order[0], 0] + dx / 2)

    def step(self, t: float, positions) -> None:
        """Call after each step, with the time reached and a positions (n, 2) getter;
        the front is sampled off the clock."""
        self.steps += 1
        if t < self.next_sample - 1e-9:
            return
        self.wall += time.perf_counter() - self.started
        self.emit("sample", t=float(t), z=self.surge_front(positions()), steps=self.steps,
                  wall=self.wall)
        while self.next_sample <= t + 1e-9:
            self.next_sample += self.config["sample_every"]
        self.started = time.perf_counter()

    def finish(self, t: float) -> None:
        self.wall += time.perf_counter() - self.started
        self.emit("done", t=float(t), steps=self.steps, wall=self.wall)
