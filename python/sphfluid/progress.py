"""Progress over simulated time on stderr, drawn by tqdm.

``Progress(end, start=t0)`` shows the simulation's own clock as the quantity,
``t = 0.52/2 s``, with the fraction done, the wall time spent and left, and the
last time step and the steps per second since it began::

     26%|██▌       | t = 0.52/2 s [00:07<00:19, dt 0.000186 s, 372 steps/s]

On a terminal the line is redrawn in place at most ten times a second. When
stderr is not a terminal (a log file, a batch job, a pipe) each redraw is a
line of its own, at most one every 30 s of wall time, plus the first and the
last, so a log stays short and readable.
"""
from __future__ import annotations

import math
import os
import sys
import time

TTY_INTERVAL = 0.1  # s of wall time between redraws on a terminal
LOG_INTERVAL = 30.0  # s between lines when stderr is not a terminal
LOG_WIDTH = 80  # characters of a line when stderr is not a terminal


class _Lines:
    """A stream for tqdm that writes each redraw as a line of its own: the
    carriage returns and the blanks that overwrite a longer line are dropped."""

    def __init__(self, stream):
        self._stream = stream

    def write(self, text: str) -> int:
        line = text.replace("\r", "").rstrip()
        if line:
            self._stream.write(line + "\n")
        return len(text)

    def flush(self) -> None:
        self._stream.flush()

    def __getattr__(self, name):  # encoding, isatty, ...
        return getattr(self._stream, name)


def _columns(stream) -> int | None:
    """None to follow the terminal's width, or LOG_WIDTH for a terminal that
    says it has no columns (a pseudo-terminal whose size was never set)."""
    try:
        return None if os.get_terminal_size(stream.fileno()).columns > 0 else LOG_WIDTH
    except (AttributeError, OSError, ValueError):
        return LOG_WIDTH


def _decimals(end: float) -> int:
    """Decimals that show a hundredth of ``end`` (0.52/2, 0.120/0.3, 52.3/100)."""
    return max(1, 2 - math.floor(math.log10(end))) if end > 0 else 3


class Progress:
    """A progress bar over simulated time, from ``start`` to ``end`` s, on stderr
    (the stream that is ``sys.stderr`` when it is made)."""

    def __init__(self, end: float, start: float = 0.0, start_step: int = 0):
        from tqdm import tqdm

        stream = sys.stderr
        tty = bool(getattr(stream, "isatty", lambda: False)())
        width = _columns(stream) if tty else LOG_WIDTH
        self.end = end if end > start else start + 1.0
        self.start_step = start_step
        self.started = time.perf_counter()
        number = f"{{n:.{_decimals(self.end)}f}}"
        self._bar = tqdm(
            total=self.end, initial=start, file=stream if tty else _Lines(stream),
            mininterval=TTY_INTERVAL if tty else LOG_INTERVAL, miniters=0,
            dynamic_ncols=width is None, ncols=width, nrows=None if width is None else 24,
            leave=True,
            bar_format="{percentage:3.0f}%|{bar}| t = " + number
                       + "/{total:g} s [{elapsed}<{remaining}{postfix}]")

    def update(self, time_now: float, sim) -> None:
        """The simulation is at ``time_now`` s (its clock): move the bar there,
        redrawing it if the last redraw is old enough."""
        steps = sim.step_count - self.start_step
        rate = steps / max(time.perf_counter() - self.started, 1e-9)
        self._bar.set_postfix_str(f"dt {sim.dt:.3g} s, {rate:,.0f} steps/s", refresh=False)
        # the last step lands on the end or just past it, or a rounding short of it
        done = self.end if time_now >= self.end * (1 - 1e-9) else time_now
        self._bar.update(done - self._bar.n)

    def close(self) -> None:
        """Draw the last state and end the line (again harmless)."""
        self._bar.close()


class Runs:
    """A progress bar over a count of runs (``sphfluid stress``, ``validate``) on
    stderr, with each run's line printed above it::

        splash    k = 1e+04  dt =  1e-03  caught blow-up ...  3.1 s
         37%|███▋      | 15/40 runs [01:12<02:01]

    ``done(line)`` prints a finished run's line and moves the bar on;
    ``line(text)`` prints any other line. Off a terminal the bar is a line of
    its own at most every LOG_INTERVAL s, between the runs' lines.
    """

    def __init__(self, total: int, what: str = "runs"):
        from tqdm import tqdm

        self._stream = sys.stderr
        tty = bool(getattr(self._stream, "isatty", lambda: False)())
        width = _columns(self._stream) if tty else LOG_WIDTH
        self._bar = tqdm(
            total=max(total, 0), file=self._stream if tty else _Lines(self._stream),
            mininterval=TTY_INTERVAL if tty else LOG_INTERVAL, miniters=0,
            dynamic_ncols=width is None, ncols=width, nrows=None if width is None else 24,
            leave=True,
            bar_format="{percentage:3.0f}%|{bar}| {n}/{total} " + what
                       + " [{elapsed}<{remaining}{postfix}]")

    def line(self, text: str) -> None:
        self._bar.write(text, file=self._stream)
        self._stream.flush()

    def done(self, text: str) -> None:
        self.line(text)
        self._bar.update(1)

    def status(self, text: str) -> None:
        """Words after the times in the bar ("2 failed"), or none."""
        self._bar.set_postfix_str(text, refresh=False)

    def advance(self) -> None:
        """A finished run with no line of its own."""
        self._bar.update(1)

    def close(self) -> None:
        self._bar.close()

    def __enter__(self) -> Runs:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
