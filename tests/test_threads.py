"""1 and 2 threads give identical states: every loop is a per-particle gather, or
runs over blocks fixed by the particles alone (the pair sums: blocks of particles
on the half lists, of cell rows by cell clusters)."""
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
    # Below 1,000 particles the step runs on one thread whatever is asked,
    # which would make the comparison vacuous.
    assert sim.threads_in_use == threads
    sim.step(steps)
    return {k: getattr(sim, k).copy() for k in
            ("ids", "positions", "velocities", "accelerations", "densities", "pressures")}


def finer(d):  # the droplet at 1,600 particles (400 as bundled)
    d["resolution"].update(spacing=0.01, smoothing_length=0.02)


def with_tension(d):
    d["fluid"]["surface_tension"] = 2.0


def wcsph_with_tension(d):  # the surface energy's node sums (docs/method-wcsph.md, W11)
    with_tension(d)
    d["solver"].update(method="wcsph", time_step="auto")


@pytest.mark.skipif(not sphfluid.has_openmp, reason="built without OpenMP")
@pytest.mark.parametrize("name,tweak", [("dam_break.json", None), ("splash.json", with_tension),
                                        ("droplet.json", finer),
                                        ("splash.json", wcsph_with_tension),
                                        ("water/wave_flume.json", None)])  # W30
def test_one_and_two_threads_give_identical_states(name, tweak):
    one = run(name, 1, 300, tweak)
    two = run(name, 2, 300, tweak)
    for key in one:
        np.testing.assert_array_equal(one[key], two[key], err_msg=key)


@pytest.mark.skipif(not sphfluid.has_openmp, reason="built without OpenMP")
def test_small_scenes_step_on_one_thread():
    small = sphfluid.Simulation(str(ROOT / "scenes" / "droplet.json"), threads=2)
    assert small.threads == 2 and small.threads_in_use == 1
    big = sphfluid.Simulation(str(ROOT / "scenes" / "dam_break.json"), threads=2)
    assert big.threads_in_use == 2
    # The count is read each step: particles added mid-run bring the threads in.
    xs = np.linspace(-0.45, 0.45, 30)
    small.add_particles(np.array([(x, y) for x in xs for y in xs[:20]]))
    assert small.n_particles == 1000 and small.threads_in_use == 2
