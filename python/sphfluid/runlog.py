"""The health log of a run: JSON Lines (``sphfluid run SCENE --log FILE``).

The first line is ``{"metadata": {...}}``, the run metadata
(``sphfluid.metadata.run_metadata``); every line after it is ``health(sim)``,
a flat object of the counters that tell whether a run is healthy: the time
step and what limited it, the density error, the energies, particles removed,
retried steps and how close the state is to each of the guard's trips
(docs/output.md, "Logs", lists them with their units).

Each line is written with a single write call and reaches the file at once,
so a run that is killed leaves whole lines.
"""
from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any


def guard_margins(sim, stats: dict | None = None) -> dict[str, float | None]:
    """How near the state is to each of the guard's trips, as a fraction of the
    level that trips it (1 trips; None when the guard does not check it):

    guard_density: the largest density over guard_density_ratio x rho0 (3 rho0);
    guard_speed: the largest speed over guard_speed_factor x the speed of sound (10 c0);
    guard_energy: the kinetic energy plus the energy carried out of the domain,
    over guard_energy_factor x the energy budget (twice what the scene can supply).
    """
    st = sim.stats() if stats is None else stats
    p = sim._solver.params
    if not p.guard:  # only non-finite values trip it
        return {"guard_density": None, "guard_speed": None, "guard_energy": None}
    rho = sim.densities
    rho_max = float(rho.max()) if len(rho) else 0.0
    budget = p.guard_energy_factor * st["energy_budget"]
    return {
        "guard_density": rho_max / (p.guard_density_ratio * p.rho0),
        "guard_speed": st["max_speed"] / (p.guard_speed_factor * p.sound_speed),
        "guard_energy": ((st["kinetic_energy"] + st["energy_removed"]) / budget
                         if budget > 0 else None),
    }


def health(sim, stats: dict | None = None) -> dict[str, Any]:
    """One line of the log for the current state of sim (``stats``: its
    ``sim.stats()``, when already at hand). SI units; energies in J per m of depth.
    dt and dt_limit are None before the first step."""
    st = sim.stats() if stats is None else stats
    stepped = st["step_count"] > 0
    return {
        "time": st["time"],
        "step": st["step_count"],
        "dt": st["dt"] if stepped else None,
        "dt_limit": st["dt_limit"] if stepped else None,
        "max_density_error": st["max_density_error"],
        "max_compression": st["max_compression"],
        "max_speed": st["max_speed"],
        "kinetic_energy": st["kinetic_energy"],
        "surface_energy": st["surface_energy"],
        "energy_budget": st["energy_budget"],
        "energy_removed": st["energy_removed"],
        "particles": st["n_particles"],
        "particles_removed": st["removed_particles"],
        "wall_crossings": st["wall_crossings"],
        "retried_steps": st["retried_steps"],
        **guard_margins(sim, st),
    }


def _finite(value):
    """value with non-finite numbers as None (JSON has no NaN or infinity)."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


class RunLog:
    """A JSON Lines file written one whole line at a time.

    append: add to an existing file (a resumed run) instead of starting it anew.
    Raises OSError when the file cannot be opened for writing.
    """

    def __init__(self, path: str | Path, append: bool = False):
        self.path = Path(path)
        # unbuffered: each line goes to the file in one write call, at once
        self._file = open(self.path, "ab" if append else "wb", buffering=0)

    def write(self, record: dict[str, Any]) -> None:
        data = memoryview((json.dumps(_finite(record), allow_nan=False) + "\n").encode())
        while data:  # a regular file takes it whole; a short write goes on from where it stopped
            data = data[self._file.write(data):]

    def write_metadata(self, sim) -> None:
        """The first line of a run: {"metadata": run_metadata(sim)}."""
        from .metadata import run_metadata

        self.write({"metadata": run_metadata(sim)})

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> RunLog:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
