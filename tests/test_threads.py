"""1 and 2 threads give identical states: every loop is a per-particle gather, or
runs over blocks of particles fixed by their number alone (the pair forces)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import sphfluid
from conftest import ROOT


def run(name, threads, steps, tweak=None):
    d = json.loads((ROOT / "scenes" / name).read_text())
    if tweak:
        tweak(d)
    sim = sphfluid.Simulation(d, threads=threads)
    assert sim.threads == threads
    sim.step(steps)
    return {k: getattr(sim, k).copy() for k in
            ("ids", "positions", "velocities", "accelerations", "densities", "pressures")}


def with_tension(d):
    d["fluid"]["surface_tension"] = 2.0


def wcsph_with_tension(d):  # the surface energy's node sums (cpp/surface_energy.hpp)
    with_tension(d)
    d["solver"].update(method="wcsph", time_step="auto")


@pytest.mark.skipif(not sphfluid.has_openmp, reason="built without OpenMP")
@pytest.mark.parametrize("name,tweak", [("dam_break.json", None), ("splash.json", with_tension),
                                        ("droplet.json", None),
                                        ("splash.json", wcsph_with_tension)])
def test_one_and_two_threads_give_identical_states(name, tweak):
    one = run(name, 1, 300, tweak)
    two = run(name, 2, 300, tweak)
    for key in one:
        np.testing.assert_array_equal(one[key], two[key], err_msg=key)
