"""Emitters and sinks (the scene's "emitters" and "sinks"; sphfluid/flows.py,
cpp/boundary/flows.hpp): the jet's lattice and rate, the sinks' counts, the
particle balance, threads, checkpoints, the scene format and its errors."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest

import sphfluid
from conftest import same_on_one_and_two_threads, set_carried_densities
from sphfluid.flows import Emitter

DX = 0.02


def scene(method="wcsph", **extra) -> dict:
    """An empty box without gravity or walls; wcsph at a fixed step."""
    d = {
        "format": "sphfluid-scene/1",
        "gravity": [0.0, 0.0],
        "domain": {"min": [0.0, 0.0], "max": [2.0, 1.0]},
        "fluid": {"rest_density": 1000.0, "gas_constant": 20.0},
        "resolution": {"spacing": DX},
        "fluid_regions": [],
        "solver": {"method": method, "time_step": 1e-4},
    }
    if method == "wcsph":
        d["fluid"]["speed_of_sound"] = 20.0
    d.update(extra)
    return d


def jet(**kw) -> dict:
    e = {"at": [0.1, 0.5], "direction": [1.0, 0.0], "width": 5 * DX, "speed": 1.0}
    e.update(kw)
    return e


def balanced(sim) -> bool:
    b = sim.balance
    return b["placed"] + b["in"] - b["out"] - b["sunk"] - b["lost"] == b["now"] == sim.n_particles


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_an_emitter_lays_rows_on_the_lattice_at_its_rate(method):
    """Without gravity a jet of 5 across at 1 m/s gives a row every dx / U = 0.02 s,
    the first at its start: each row appears where it has travelled since it left
    the nozzle, dx apart across, at U."""
    sim = sphfluid.Simulation(scene(method, emitters=[jet(start=0.01)]))
    dt = sim.scene.time_step
    rows = []
    for _ in range(1000):  # to t = 0.1 s: rows at t = 0.01, 0.03, ..., 0.09
        n = sim.n_particles
        sim.step()
        if sim.n_particles > n:
            new = np.argsort(sim.ids)[n:]
            x, v = sim.positions[new], sim.velocities[new]
            assert len(new) == 5 and np.ptp(x[:, 0]) == 0.0
            assert np.sort(x[:, 1]) == pytest.approx(0.5 + (np.arange(5) - 2) * DX, abs=1e-12)
            assert 0.0 <= x[0, 0] - 0.1 <= 1.0 * dt * (1 + 1e-9)
            assert v[:, 0] == pytest.approx(1.0, abs=0.01) and np.abs(v[:, 1]).max() < 0.01
            rows.append(sim.time)
    assert rows == pytest.approx(0.01 + 0.02 * np.arange(5), abs=1.01 * dt)
    assert sim.balance["in"] == 5 * 5 == sim.n_particles and balanced(sim)
    if method == "wcsph":  # the jet keeps its lattice (barely pushed)
        along = np.unique(np.round(sim.positions[:, 0], 3))
        assert np.diff(along) == pytest.approx(DX, rel=0.02)


def test_a_speed_table_is_integrated():
    """Speed ramped 0 -> 2 m/s over 0.1 s: the jet has advanced 0.1 m by then, a row
    each spacing (the first at the start) and none after its stop."""
    sim = sphfluid.Simulation(scene(emitters=[jet(width=DX, speed=[[0, 0], [0.1, 2.0]],
                                                  stop=0.1)]))
    sim.step(1000)
    assert sim.balance["in"] == math.floor(0.1 / DX + 1e-9) + 1
    sim.step(500)
    assert sim.balance["in"] == math.floor(0.1 / DX + 1e-9) + 1  # stopped


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_sinks_remove_what_enters_them_and_the_balance_holds(method):
    """A block moving right at 2 m/s into a sink: every particle that has crossed the
    sink's edge is gone and counted as sunk, apart from those that left the domain."""
    d = scene(method, fluid_regions=[{"shape": "rectangle", "min": [0.2, 0.3],
                                      "max": [0.6, 0.7], "velocity": [2.0, 0.0]}],
              sinks=[{"shape": "rectangle", "min": [1.0, 0.0], "max": [1.5, 1.0]},
                     {"shape": "circle", "center": [1.8, 0.5], "radius": 0.1}],
              emitters=[jet(at=[0.05, 0.15], speed=2.0)])
    sim = sphfluid.Simulation(d)
    placed = sim.n_particles
    for _ in range(6):
        sim.step(500)
        assert balanced(sim)
        x = sim.positions
        assert not ((x[:, 0] >= 1.0) & (x[:, 0] <= 1.5)).any()
    b = sim.balance
    assert b["placed"] == placed and b["sunk"] > 0 and b["in"] > 0
    assert sim.stats()["particles_sunk"] == b["sunk"]
    assert sim.stats()["particles_lost"] == sim.removed_particles == b["lost"]


def test_one_and_two_threads_identical_with_particles_entering_and_leaving():
    d = scene("wcsph", gravity=[0.0, -9.81],
              walls=[[[0.0, 0.0], [2.0, 0.0]]],
              emitters=[jet(at=[0.3, 0.6], direction=[1, -1], speed=1.5)],
              sinks=[{"shape": "rectangle", "min": [1.2, 0.0], "max": [2.0, 0.3]}])
    d["solver"]["time_step"] = "auto"
    assert same_on_one_and_two_threads(d, 0.6).balance["in"] > 100


def test_a_checkpoint_mid_emission_continues_bit_for_bit(tmp_path):
    d = scene("wcsph", emitters=[jet(speed=[[0, 0.5], [0.05, 1.5]])],
              sinks=[{"shape": "circle", "center": [0.2, 0.5], "radius": 0.05}])
    a = sphfluid.Simulation(d)
    a.step(333)  # between two rows
    a.save_state(tmp_path / "c.npz")
    a.step(700)
    b = sphfluid.Simulation.from_checkpoint(tmp_path / "c.npz")
    b.step(700)
    assert a.balance == b.balance and a.balance["sunk"] > 0
    assert np.array_equal(a.ids, b.ids) and np.array_equal(a.positions, b.positions)


def test_the_scene_round_trips_with_its_emitters_and_sinks():
    d = scene(emitters=[jet(name="tap", speed=[[0, 1], [1, 2]], start=0.5, stop=2.0),
                        {"at": [1.0, 0.9]}],
              sinks=[{"shape": "polygon", "points": [[1.5, 0.1], [1.9, 0.1], [1.7, 0.4]]}])
    s = sphfluid.load_scene(d)
    assert sphfluid.load_scene(json.loads(json.dumps(s.to_dict()))) == s
    assert s.emitters[1].direction == (0.0, -1.0) and s.emitters[1].width is None
    assert s.emitters[0].table() == ([0.0, 1.0], [1.0, 2.0])


def test_an_emitter_counts_in_the_expected_speed():
    """wcsph's default speed of sound is 10 x the fastest the fluid is expected to
    move: a jet's speed and its fall to the floor count."""
    d = scene(gravity=[0.0, -9.81], emitters=[jet(at=[1.0, 0.8], speed=3.0)])
    del d["fluid"]["speed_of_sound"]
    expected = math.sqrt(3.0**2 + 2 * 9.81 * 0.8)
    assert sphfluid.simulation.expected_top_speed(sphfluid.load_scene(d)) == \
        pytest.approx(expected)


@pytest.mark.parametrize("change, where, words", [
    (lambda d: d["emitters"][0].update(speed=[[0, 1], [0, 2]]), "emitters[0].speed[1]",
     "must increase"),
    (lambda d: d["emitters"][0].update(speed=[[1, 1], [0.5, 2]]), "emitters[0].speed[1]",
     "must increase"),
    (lambda d: d["emitters"][0].update(speed=-1), "emitters[0].speed", ">= 0"),
    (lambda d: d["emitters"][0].update(start=1.0, stop=0.5), "emitters[0].stop",
     "after start"),
    (lambda d: d["emitters"][0].update(direction=[0, 0]), "emitters[0].direction",
     "not be [0, 0]"),
    (lambda d: d["emitters"][0].update(at=[1.0, 0.99]), "emitters[0]", "outside the domain"),
    (lambda d: d["emitters"][0].update(at=[2.5, 0.5]), "emitters[0]", "outside the domain"),
    (lambda d: d.update(walls=[[[0.0, 0.45], [0.3, 0.55]]]), "emitters[0]", "crosses its nozzle"),
    (lambda d: d["emitters"][0].update(width=0), "emitters[0].width", ""),
    (lambda d: d["emitters"][0].update(rate=3), "emitters[0].rate", "unknown key"),
    (lambda d: d["emitters"][0].update(speed=15.0) or d["solver"].update(time_step=2e-3),
     "emitters[0].speed", "at most one"),
    (lambda d: d.update(sinks=[{"shape": "rectangle", "min": [3, 0], "max": [4, 1]}]),
     "sinks[0]", "outside the domain"),
    (lambda d: d.update(sinks=[{"shape": "circle", "center": [1, 0.5], "radius": 0.2}],
                        fluid_regions=[{"shape": "rectangle", "min": [0.9, 0.4],
                                        "max": [1.3, 0.6]}]),
     "sinks[0]", "initial fluid"),
    (lambda d: d.update(sinks=[{"shape": "circle", "center": [1, 0.5]}]), "sinks[0].radius",
     "missing"),
])
def test_bad_emitters_and_sinks_are_refused_by_json_path(change, where, words):
    d = scene(emitters=[jet()])
    change(d)
    with pytest.raises(sphfluid.SceneError) as e:
        sphfluid.load_scene(d)
    lines = [line for line in str(e.value).splitlines() if line.strip().startswith(where + ":")]
    assert lines and words in lines[0], str(e.value)


def test_adding_an_emitter_to_a_run_checks_it_and_keeps_the_run():
    sim = sphfluid.Simulation(scene(emitters=[jet()]))
    sim.step(100)
    n = sim.n_particles
    with pytest.raises(sphfluid.SceneError, match="outside the domain"):
        sim.add_emitter(Emitter(at=(5.0, 0.5)))
    assert len(sim.scene.emitters) == 1 and sim.n_particles == n
    sim.add_emitter(Emitter(at=(1.0, 0.9), start=sim.time))
    sim.step(400)
    assert len(sim.scene.emitters) == 2 and (sim.positions[:, 1] < 0.9).any()
    assert balanced(sim)


def test_placing_particles_through_the_api_keeps_the_balance():
    sim = sphfluid.Simulation(scene(emitters=[jet()]))
    sim.step(300)
    sim.add_particles([[1.0, 0.5], [3.0, 0.5]])  # the second is outside: lost at once
    assert balanced(sim) and sim.balance["lost"] == 1
    sim.set_state(sim.positions[:4].copy(), sim.velocities[:4].copy())
    assert balanced(sim) and sim.n_particles == 4


def _rect(x0, y0, x1, y1) -> dict:
    return {"shape": "rectangle", "min": [x0, y0], "max": [x1, y1]}


def basin(solver: dict) -> dict:
    """A tap 0.1 m wide at 1 m/s for 1.5 s, 0.2 m above the rim of a basin 0.6 m
    wide (benchmarks/experiments/basin_fill.py): 375 particles, 0.25 m of water."""
    return {
        "format": "sphfluid-scene/1",
        "domain": {"min": [0, 0], "max": [1, 1.2]},
        "fluid": {"rest_density": 1000, "viscosity": 0.001},
        "resolution": {"spacing": DX},
        "fluid_regions": [],
        "walls": [{"polyline": [[0.2, 0.8], [0.2, 0.0], [0.8, 0.0], [0.8, 0.8]]}],
        "emitters": [{"at": [0.5, 1.0], "width": 0.1, "speed": 1.0, "stop": 1.5}],
        "solver": {"method": "wcsph", "time_step": "auto", **solver},
    }


@pytest.mark.parametrize("solver, tolerance", [
    ({"density": "summation"}, 0.03),  # measured 0.250 m at t = 3 s
    ({}, 0.30),  # wcsph's default (W26b): measured 0.292 m
])
def test_a_tap_fills_a_basin_to_the_level_its_inflow_predicts(solver, tolerance):
    """375 particles x spacing^2 over 0.6 m: 0.25 m. W26 (`"free_surface":
    "density_floor"`) leaves 0.78 m of loose spray (docs/method-wcsph.md)."""
    sim = sphfluid.Simulation(basin(solver))
    sim.advance_to(3.0)
    x = sim.positions
    assert sim.balance["in"] == 375 and sim.balance["lost"] == 0
    assert ((x[:, 0] > 0.2) & (x[:, 0] < 0.8) & (x[:, 1] < 0.8)).all()
    middle = np.abs(x[:, 0] - 0.5) < 0.2
    level = np.percentile(x[middle, 1], 98) + 0.5 * DX
    assert level == pytest.approx(0.25, rel=tolerance)


@pytest.mark.parametrize("free_surface", ["density_floor", "pressure_floor"])
def test_an_emitter_with_shifting_fills_the_basin(free_surface):
    """The particles an emitter adds were not moved by the last drift's shift,
    so their share of the rate (W27) is zero: it was read from uninitialised
    memory and the basin blew up at step 159 with any shifting coefficient."""
    sim = sphfluid.Simulation(basin({"shifting": 1.0, "free_surface": free_surface}))
    sim.advance_to(0.5)
    assert sim.balance["in"] > 100 and sim.balance["lost"] == 0
    assert np.isfinite(sim.densities).all() and (sim.densities > 500).all()


@pytest.mark.parametrize("free_surface", ["density_floor", "pressure_floor"])
def test_spray_keeps_its_stretched_density_under_w26b_and_no_tension(free_surface):
    """Two particles flying apart: the carried density falls as they separate.
    W26 floors it at rho0; W26b keeps it (886.7 kg/m^3 here) and floors the
    pressure at p_b = 0 instead: no tension in either."""
    d = scene("wcsph", fluid_regions=[_rect(0.9, 0.48, 0.94, 0.5)])
    d["solver"]["free_surface"] = free_surface
    sim = sphfluid.Simulation(d)
    sim.set_state(sim.positions.copy(), np.array([[-1.0, 0.0], [1.0, 0.0]]))
    sim.step(300)
    assert np.ptp(sim.positions[:, 0]) > 0.07  # apart, beyond each other's support
    assert (sim.pressures == 0.0).all()
    if free_surface == "density_floor":
        assert (sim.densities == 1000.0).all()
    else:
        assert (sim.densities < 900.0).all()


@pytest.mark.parametrize("carried", [640.0, 900.0])
def test_stretched_spray_that_gathers_again_holds_no_tension(carried):
    """A block of fluid on the lattice whose carried density is below its summed
    density (spray stretched in flight that has gathered again): W26b floors
    its pressure at p_b (0 here) inside as at its surface. Under the Tait
    tension (-0.95 B at 640 kg/m^3) it tore itself apart (the terrain scene)."""
    d = scene("wcsph", fluid_regions=[_rect(0.3, 0.3, 0.54, 0.54)])  # 12 x 12
    d["solver"]["free_surface"] = "pressure_floor"  # W26b, the default
    sim = sphfluid.Simulation(d)
    inside = sim._solver.snapshot()["fields"]["kernel_sum"] >= 0.95
    assert inside.sum() >= 64  # most of the block is away from its surface
    set_carried_densities(sim, carried)
    sim.step(200)
    assert (sim.pressures == 0.0).all()
    assert np.abs(sim.velocities).max() < 1e-9
    assert (sim.densities == carried).all()  # uniform: the diffusion has nothing to move


def test_a_jet_too_fast_for_its_fluid_is_refused():
    d = scene("seed", emitters=[jet(speed=5.0)])  # the seed's sound speed: sqrt(20)
    with pytest.raises(sphfluid.SceneError, match=r"emitters\[0\]\.speed: 5 m/s is not below"):
        sphfluid.load_scene(d)
