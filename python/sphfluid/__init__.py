"""sphfluid: 2D Smoothed Particle Hydrodynamics with a C++ core.

    >>> import sphfluid
    >>> sim = sphfluid.Simulation(sphfluid.load_scene("scenes/dam_break.json"))
    >>> sim.run(0.1)
"""
from __future__ import annotations

from ._core import __version__, has_openmp
from .scene import FORMAT, Scene, SceneError, load_scene
from .simulation import InstabilityError, Simulation

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
