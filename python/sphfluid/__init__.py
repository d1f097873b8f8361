"""sphfluid: 2D Smoothed Particle Hydrodynamics with a C++ core.

    >>> import sphfluid
    >>> sim = sphfluid.Simulation(sphfluid.load_scene("scenes/dam_break.json"))
    >>> sim.run(0.1)
"""
from __future__ import annotations

from ._dispatch import load as _load_core

_load_core()  # sphfluid._core: this build's core, or the fastest of a wheel's for this CPU

from ._core import __version__, has_openmp  # noqa: E402
from .scene import FORMAT, Scene, SceneError, load_scene  # noqa: E402
from .simulation import InstabilityError, Simulation  # noqa: E402

__all__ = [
    "FORMAT",
    "InstabilityError",
    "Scene",
    "SceneError",
    "Simulation",
    "__version__",
    "has_openmp",
    "load_scene",
]
