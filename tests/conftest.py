"""Shared fixtures: paths, a small scene factory, and a brute-force reference."""
from __future__ import annotations

import copy
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
# the seed's scenes, then the same flows in water (wcsph with the continuity density)
SCENES = sorted((ROOT / "scenes").glob("*.json")) + sorted((ROOT / "scenes" / "water").glob("*.json"))
SCENE_IDS = [p.relative_to(ROOT / "scenes").with_suffix("").as_posix() for p in SCENES]
BENCHMARKS = ROOT / "benchmarks"  # drivers and experiments, not in the wheel
sys.path.insert(0, str(Path(__file__).resolve().parent))


def benchmark_module(relative: str):
    """A Python file of benchmarks/ (e.g. "peers/peers.py") imported as a module, the
    way `sphfluid bench` imports it."""
    from sphfluid.bench import load_benchmark

    return load_benchmark(BENCHMARKS, relative)

BASE_SCENE = {
    "format": "sphfluid-scene/1",
    "name": "test box",
    "gravity": [0.0, -9.81],
    "domain": {"min": [-0.1, -0.1], "max": [1.1, 1.1]},
    "fluid": {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 0.5,
              "surface_tension": 0.0},
    "resolution": {"spacing": 0.05, "smoothing_length": 0.1},
    "fluid_regions": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [0.5, 0.5]}],
    "walls": [{"polyline": [[0.0, 1.0], [0.0, 0.0], [1.0, 0.0], [1.0, 1.0]]}],
    "solver": {"method": "seed", "time_step": 0.001},
    "duration": 0.05,
}


def same_on_one_and_two_threads(scene: dict, until: float):
    """Runs `scene` to time `until` on 1 and then 2 threads and asserts the same
    particles (by id) at the same positions, the same balance and the same walls;
    returns the 2-thread Simulation for further checks."""
    import numpy as np

    import sphfluid

    runs = []
    for threads in (1, 2):
        sim = sphfluid.Simulation(scene, threads=threads)
        sim.advance_to(until)
        runs.append(sim)
    one, two = runs
    assert one.balance == two.balance
    o1, o2 = np.argsort(one.ids), np.argsort(two.ids)
    assert np.array_equal(one.ids[o1], two.ids[o2])
    assert np.array_equal(one.positions[o1], two.positions[o2])
    assert np.array_equal(one.velocities[o1], two.velocities[o2])
    assert np.array_equal(one.walls, two.walls)
    return two


def set_carried_densities(sim, densities) -> None:
    """Overwrite a wcsph simulation's carried densities (through the core's
    snapshot, as a checkpoint restores them): states no scene starts from."""
    snap = sim._solver.snapshot()
    snap["fields"]["density"][:] = densities
    sim._solver.restore(snap)


@pytest.fixture
def scene_dict():
    """A fresh copy of a small valid scene, to modify per test."""
    return copy.deepcopy(BASE_SCENE)


def write_boom_scene(folder):
    """BASE_SCENE made to blow up at its first step (pressures overflow to inf,
    no viscosity, a fixed 0.01 s step), written to folder/boom.json."""
    d = json.loads(json.dumps(BASE_SCENE))
    d["fluid"]["gas_constant"] = 1e306
    d["fluid"]["viscosity"] = 0.0
    d["solver"]["time_step"] = 0.01
    d["duration"] = 5.0
    path = folder / "boom.json"
    path.write_text(json.dumps(d))
    return path
