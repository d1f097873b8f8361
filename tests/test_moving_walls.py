"""Moving walls (a polyline's "motion"; sphfluid/flows.py WallMotion,
cpp/boundary/walls.hpp): the motion's tables, Galilean invariance of the wall
terms, no particle through a moving wall however fast it moves, threads,
checkpoints, the scene format and its errors."""
from __future__ import annotations

import json

import numpy as np
import pytest

import sphfluid
from conftest import same_on_one_and_two_threads

DX = 0.02


def box(method: str, velocity=(0.0, 0.0), motion=None) -> dict:
    """Water 0.3 x 0.2 m in an open box of the same width, fixed or moving."""
    wall = {"polyline": [[0.2, 0.5], [0.2, 0.2], [0.5, 0.2], [0.5, 0.5]]}
    if motion:
        wall["motion"] = motion
    return {
        "format": "sphfluid-scene/1",
        "domain": {"min": [0.0, 0.0], "max": [3.0, 1.0]},
        "fluid": {"rest_density": 1000.0, "speed_of_sound": 20.0, "gas_constant": 100.0,
                  "viscosity": {"wcsph": 0.0, "dfsph": 0.001}.get(method, 30.0)},
        "resolution": {"spacing": DX},
        "fluid_regions": [{"shape": "rectangle", "min": [0.2, 0.2], "max": [0.5, 0.4],
                           "velocity": list(velocity)}],
        "walls": [wall],
        "solver": {"method": method, "time_step": 2e-4 if method == "wcsph" else 5e-4},
    }


@pytest.mark.parametrize("method, steps", [("wcsph", 300), ("seed", 100), ("dfsph", 30)])
def test_a_box_in_uniform_motion_carries_its_water_as_a_resting_box_does(method, steps):
    """Galilean invariance: water moving with its box at 0.5 m/s is, relative to
    the box, the water of the box at rest, to round-off (the walls' pressure,
    viscosities and rate take velocities relative to the wall). dfsph's box at
    rest grows a difference of 1e-15 m/s in one velocity to 1e-11 m/s in 30
    steps and 5e-4 m/s in 100 (its solves' projection on k >= 0 switches):
    30 steps."""
    rest = sphfluid.Simulation(box(method), threads=1)
    moving = sphfluid.Simulation(
        box(method, (0.5, 0.0), {"translation": [[0, 0, 0], [2, 1, 0]]}), threads=1)
    for sim in (rest, moving):
        sim.step(steps)
    o, p = np.argsort(rest.ids), np.argsort(moving.ids)
    t = moving.time
    assert np.abs(moving.positions[p] - [0.5 * t, 0.0] - rest.positions[o]).max() < 1e-9
    assert np.abs(moving.velocities[p] - [0.5, 0.0] - rest.velocities[o]).max() < 1e-8
    assert moving.walls[1] == pytest.approx(np.array([[0.2 + 0.5 * t, 0.2], [0.5 + 0.5 * t, 0.2]]))


def sliding_floor(method: str, slide: bool) -> dict:
    """Inviscid water at rest in the box, its floor's surface sliding at 1 m/s or not."""
    d = box(method)
    d["fluid"]["viscosity"] = 0.0
    floor = {"polyline": [[0.2, 0.2], [0.5, 0.2]]}
    if slide:
        floor["velocity"] = [1.0, 0.0]
    d["walls"] = [[[0.2, 0.5], [0.2, 0.2]], floor, [[0.5, 0.2], [0.5, 0.5]]]
    return d


@pytest.mark.parametrize("method, steps", [("wcsph", 100), ("dfsph", 30)])
def test_inviscid_water_does_not_feel_its_floor_slide(method, steps):
    """A sliding surface moves no fluid across it, and without viscosity nothing
    couples the slide to the water: the run is the one over a still floor, to
    the bit. (dfsph's divergence term once took the floor's surface velocity for
    a moving wall's: 1.5e-10 m/s apart after 30 steps.)"""
    still, sliding = (sphfluid.Simulation(sliding_floor(method, s), threads=1)
                      for s in (False, True))
    for sim in (still, sliding):
        sim.step(steps)
    assert np.abs(still.velocities).max() > 1e-4  # (the water settles: something to compare)
    assert np.array_equal(still.velocities, sliding.velocities)
    assert np.array_equal(still.positions, sliding.positions)


def piston(method: str, motion: dict) -> dict:
    return {
        "format": "sphfluid-scene/1",
        "domain": {"min": [-0.3, -0.05], "max": [2.05, 0.8]},
        "fluid": {"rest_density": 1000.0, "viscosity": 30.0 if method == "seed" else 0.001,
                  "gas_constant": 200.0},
        "resolution": {"spacing": DX},
        "fluid_regions": [{"shape": "rectangle", "min": [0.0, 0.0], "max": [2.0, 0.3]}],
        "walls": [[[-0.3, 0.0], [2.0, 0.0]], [[2.0, 0.0], [2.0, 0.7]],
                  {"polyline": [[0.0, 0.0], [0.0, 0.8]], "motion": motion}],
        "solver": {"method": method, "time_step": "auto"},
    }


FAST_PISTON = {"translation": [[0, 0, 0], [0.1, 0.3, 0], [0.2, 0.3, 0], [0.25, 0.0, 0]]}
PADDLE = {"rotation": [[0, 0], [0.15, -0.6], [0.3, 0.0]], "about": [0.0, 0.0]}


@pytest.mark.parametrize("method", ["seed", "wcsph", "dfsph"])
@pytest.mark.parametrize("motion", [FAST_PISTON, PADDLE], ids=["piston", "paddle"])
def test_no_particle_passes_through_a_moving_wall(method, motion):
    """A piston thrust 0.3 m in 0.1 s (3 m/s, ten times the water's wave speed)
    and back, and a paddle hinged at the floor swung 0.6 rad and back: after
    every step each particle is on the water's side of the moving wall (which
    reaches the domain's top: splashes leave the domain there, and nothing can
    pass over it)."""
    sim = sphfluid.Simulation(piston(method, motion))
    for _ in range(4000):
        if sim.time >= 0.3:
            break
        sim.step()
        (a, b) = sim.walls[2]
        t = (b - a) / np.linalg.norm(b - a)
        n = np.array([t[1], -t[0]])  # towards the water (+x at rest)
        x = sim.positions
        along = (x - a) @ t
        beside = (along >= 0) & (along <= np.linalg.norm(b - a))
        assert ((x[beside] - a) @ n > 0).all(), f"t = {sim.time}"
    assert sim.time >= 0.3
    assert (sim.positions[:, 0] > sim.walls[2][:, 0].min()).all()
    assert sim.stats()["max_speed"] > 1.0  # the wall did push the water


def test_the_adaptive_step_follows_a_fast_wall():
    """dt <= cfl h / (c0 + |v|max + the walls' speed): a wall never moves further
    than the flow's limit in one step."""
    d = piston("wcsph", FAST_PISTON)
    sim = sphfluid.Simulation(d)
    c0 = sim._solver.params.c0
    sim.advance_to(0.05)  # the piston at 3 m/s
    v = np.sqrt((sim.velocities**2).sum(1)).max()
    limit = sim.scene.cfl * 0.5 * sim.smoothing_length  # wcsph's step length: h/2
    assert sim.dt <= limit / (c0 + v + 3.0) * (1 + 1e-6)


@pytest.mark.parametrize("motion", [FAST_PISTON, PADDLE], ids=["piston", "paddle"])
def test_one_and_two_threads_identical_with_a_moving_wall(motion):
    same_on_one_and_two_threads(piston("wcsph", motion), 0.2)


def test_a_checkpoint_mid_motion_continues_bit_for_bit(tmp_path):
    a = sphfluid.Simulation(piston("wcsph", FAST_PISTON))
    a.advance_to(0.07)
    a.save_state(tmp_path / "c.npz")
    a.step(300)
    b = sphfluid.Simulation.from_checkpoint(tmp_path / "c.npz")
    assert b.walls[2][0][0] == pytest.approx(0.3 * 0.07 / 0.1)  # placed at its time
    b.step(300)
    assert np.array_equal(a.walls, b.walls)
    assert np.array_equal(a.positions, b.positions) and np.array_equal(a.velocities, b.velocities)


def test_the_scene_round_trips_with_its_motions():
    s = sphfluid.load_scene(piston("seed", {"translation": [[0, 0, 0], [1, 0.1, 0.0]],
                                            "rotation": [[0, 0], [1, 0.2]],
                                            "about": [0.0, 0.35]}))
    again = sphfluid.load_scene(json.loads(json.dumps(s.to_dict())))
    assert again == s and s.wall_motions[2].about == (0.0, 0.35)
    assert s.wall_motions[:2] == (None, None)


@pytest.mark.parametrize("motion, where, words", [
    ({"translation": [[0, 0, 0], [0, 0.1, 0]]}, "walls[2].motion.translation[1]",
     "must increase"),
    ({"rotation": [[1, 0], [0.5, 0.1]]}, "walls[2].motion.rotation[1]", "must increase"),
    ({"translation": [[0, 0, 0], [1, -1.0, 0]]}, "walls[2].motion", "outside the domain"),
    ({"rotation": [[0, 0], [1, 3.2]], "about": [0.0, 0.3]}, "walls[2].motion",
     "outside the domain"),
    ({}, "walls[2].motion", "translation"),
    ({"translation": [[0, 1]]}, "walls[2].motion.translation[0]", "[t, x, y]"),
    ({"spin": 1}, "walls[2].motion.spin", "unknown key"),
])
def test_bad_motions_are_refused_by_json_path(motion, where, words):
    with pytest.raises(sphfluid.SceneError) as e:
        sphfluid.load_scene(piston("wcsph", motion))
    lines = [line for line in str(e.value).splitlines() if line.strip().startswith(where + ":")]
    assert lines and words in lines[0], str(e.value)


def test_a_fixed_step_may_not_let_a_wall_outrun_it():
    """At most half a support a step: the piston returns at 6 m/s; the seed's
    support is 0.04 m, so 0.003 s (0.45 supports) passes and 0.01 s does not."""
    d = piston("seed", FAST_PISTON)
    d["solver"]["time_step"] = 0.003
    sphfluid.load_scene(d)
    d["solver"]["time_step"] = 0.01
    with pytest.raises(sphfluid.SceneError, match=r"walls\[2\]\.motion: moves the wall up to "
                       r"6 m/s, 1.5 supports a fixed step"):
        sphfluid.load_scene(d)


def test_a_wall_cannot_both_slide_and_move():
    d = piston("wcsph", FAST_PISTON)
    d["walls"][2]["velocity"] = [0.0, 1.0]
    with pytest.raises(sphfluid.SceneError, match=r"walls\[2\]\.motion: a wall cannot both"):
        sphfluid.load_scene(d)


def test_paraview_output_carries_the_moving_wall_per_frame(tmp_path):
    """--format vtk: a walls file whenever the walls moved since the last frame,
    listed in frames.pvd at each frame's time, holding the wall where it was."""
    pytest.importorskip("pyevtk")
    from test_output import pvd_datasets, segments

    from sphfluid.cli import main

    d = piston("wcsph", {"translation": [[0, 0, 0], [0.2, 0.1, 0], [0.4, 0.0, 0]]})
    (tmp_path / "p.json").write_text(json.dumps(d))
    out = tmp_path / "out"
    assert main(["run", str(tmp_path / "p.json"), "--duration", "0.4", "--out", str(out),
                 "--format", "vtk", "--every", "0.1", "--quiet"]) == 0
    walls = {t: f for t, part, _, f in pvd_datasets(out / "frames.pvd") if part == "1"}
    assert sorted(walls) == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
    assert len(set(walls.values())) == 5  # each frame's walls differ from the last's
    for t, f in walls.items():
        piston_x = segments(out / f)[2][:, 0]
        assert piston_x == pytest.approx([0.1 - abs(t - 0.2) / 2] * 2, abs=1e-12)
