"""The Python API contract (issue: core engine): names, shapes, views, errors."""
from __future__ import annotations

import json

import numpy as np
import pytest
import sphfluid
from conftest import ROOT
from sphfluid import _core


def test_public_names():
    for name in ("load_scene", "Simulation", "SceneError", "InstabilityError", "__version__"):
        assert hasattr(sphfluid, name)
    assert issubclass(sphfluid.SceneError, ValueError)
    assert issubclass(sphfluid.InstabilityError, RuntimeError)
    assert isinstance(_core.has_openmp, bool)


def test_simulation_state_and_stepping(scene_dict):
    sim = sphfluid.Simulation(sphfluid.load_scene(scene_dict))
    n = sim.n_particles
    assert n == 100
    assert sim.time == 0.0 and sim.step_count == 0
    assert sim.smoothing_length == pytest.approx(0.1)
    assert sim.particle_mass == pytest.approx(_core.kernels.lattice_mass(1000.0, 0.05, 0.1))
    for name in ("positions", "velocities", "accelerations"):
        assert getattr(sim, name).shape == (n, 2)
    for name in ("densities", "pressures", "ids"):
        assert getattr(sim, name).shape == (n,)
    assert sorted(sim.ids) == list(range(n))
    sim.step(5)
    assert sim.step_count == 5 and sim.time == pytest.approx(0.005)
    sim.run(0.01)
    assert sim.step_count == 15
    sim.run()  # the scene's duration, 0.05 s
    assert sim.time == pytest.approx(0.065)
    st = sim.stats()
    for key in ("kinetic_energy", "max_density_error", "removed_particles", "max_speed",
                "time", "step_count", "n_particles"):
        assert key in st
    assert st["kinetic_energy"] > 0


def test_arrays_are_read_only_views_that_stay_valid(scene_dict):
    sim = sphfluid.Simulation(scene_dict)
    x = sim.positions
    assert not x.flags.writeable and x.base is not None  # a view of native memory
    with pytest.raises(ValueError):
        x[0, 0] = 1.0
    snapshot = x.copy()
    sim.step(10)
    # The old view still holds the old state (storage is re-sorted each step) and
    # stays valid even after the particle count changes.
    np.testing.assert_array_equal(x, snapshot)
    sim.set_state(np.zeros((3, 2)) + 0.5, np.zeros((3, 2)))
    np.testing.assert_array_equal(x, snapshot)
    assert sim.positions.shape == (3, 2)


def test_set_state_changes_particle_count_and_ids(scene_dict):
    sim = sphfluid.Simulation(scene_dict)
    pos = np.array([[0.2, 0.2], [0.25, 0.2], [0.3, 0.2]])
    sim.set_state(pos, np.zeros_like(pos), ids=[7, 8, 9])
    assert sim.n_particles == 3
    assert sorted(sim.ids) == [7, 8, 9]
    sim.set_state(pos[:2], np.zeros((2, 2)))
    assert sorted(sim.ids) == [0, 1]


def test_compute_forces_moves_nothing(scene_dict):
    sim = sphfluid.Simulation(scene_dict)
    sim.step(3)
    order = np.argsort(sim.ids)
    x = sim.positions[order].copy()
    v = sim.velocities[order].copy()
    sim.compute_forces()
    order = np.argsort(sim.ids)
    np.testing.assert_array_equal(sim.positions[order], x)
    np.testing.assert_array_equal(sim.velocities[order], v)
    assert sim.step_count == 3


def test_particles_leaving_the_domain_are_removed_and_counted(scene_dict):
    scene_dict["walls"] = []
    scene_dict["domain"] = {"min": [-0.1, -0.5], "max": [1.1, 1.1]}
    scene_dict["fluid"].update(gas_constant=20.0, viscosity=5.0)  # a calm blob
    sim = sphfluid.Simulation(scene_dict)
    n = sim.n_particles
    sim.run(0.5)  # free fall, no floor: everything drops out of the domain
    assert sim.removed_particles == n - sim.n_particles > 0


@pytest.mark.parametrize("call,message", [
    (lambda s: s.step(-1), "n must be >= 0"),
    (lambda s: s.run(-1.0), "duration must be >= 0"),
    (lambda s: s.set_state(np.zeros((3, 3)), np.zeros((3, 3))), r"positions: expected an array of shape \(n, 2\)"),
    (lambda s: s.set_state(np.zeros((3, 2)), np.zeros((2, 2))), "positions and velocities differ in length"),
    (lambda s: s.set_state(np.full((1, 2), np.nan), np.zeros((1, 2))), "position 0 is not finite"),
    (lambda s: s.advance_to(float("nan")), "t_end must be finite, got nan"),
    (lambda s: s.advance_to(float("inf")), "t_end must be finite, got inf"),
    (lambda s: s.advance_to(1.0, max_steps=-1), "max_steps must be >= 0"),
    (lambda s: s.run(float("nan")), "duration must be finite"),
    (lambda s: s.run(0.1, every=float("nan")), "every must be finite"),
    (lambda s: s.run(0.1, every=0.0), "every must be > 0"),
    (lambda s: s.set_state(np.zeros((2, 2)), np.zeros((2, 2)), ids=[3, 3]), "ids must be distinct"),
    (lambda s: s.set_state(np.zeros((2, 2)), np.zeros((2, 2)), ids=[-1, 3]), "ids must be >= 0"),
    (lambda s: s.set_state(np.zeros((1, 2)), np.zeros((1, 2)), ids=[1.5]), "ids must be integers"),
    (lambda s: setattr(s, "threads", 10**6), "more than 4 times this machine's"),
])
def test_bad_calls_raise_clear_errors(scene_dict, call, message):
    sim = sphfluid.Simulation(scene_dict)
    with pytest.raises(ValueError, match=message):
        call(sim)


@pytest.mark.parametrize("call,message", [
    (lambda s: s.step(1.5), "n must be an integer, got 1.5"),
    (lambda s: s.step(True), "n must be an integer, got True"),
    (lambda s: setattr(s, "threads", 1.5), "threads must be an integer, got 1.5"),
])
def test_counts_must_be_integers(scene_dict, call, message):
    sim = sphfluid.Simulation(scene_dict)
    with pytest.raises(TypeError, match=message):
        call(sim)
    with pytest.raises(TypeError, match="threads must be an integer"):
        sphfluid.Simulation(scene_dict, threads=2.0)


def test_a_huge_step_count_is_taken_in_calls_the_core_accepts(scene_dict, monkeypatch):
    from sphfluid import simulation

    monkeypatch.setattr(simulation, "_STEPS_PER_CALL", 7)
    sim = sphfluid.Simulation(scene_dict, threads=1)
    sim.step(16)  # 7 + 7 + 2
    assert sim.step_count == 16
    assert sphfluid.Simulation(scene_dict, threads=np.int64(1)).threads == 1


def test_blow_up_raises_instability_error_naming_step_and_particle(scene_dict):
    scene_dict["fluid"]["gas_constant"] = 1e306  # pressures overflow to inf
    scene_dict["fluid"]["viscosity"] = 0.0
    scene_dict["solver"]["time_step"] = 0.01
    sim = sphfluid.Simulation(scene_dict)
    with pytest.raises(sphfluid.InstabilityError, match=r"step \d+ \(t = .* s\): particle id \d+ "
                       r"got a non-finite velocity or position"):
        sim.run(5.0)


def test_run_shows_progress_over_simulated_time(scene_dict, capsys):
    sim = sphfluid.Simulation(scene_dict)
    sim.run(0.02)
    assert capsys.readouterr().err == ""
    sim.run(0.03, progress=True)  # from t = 0.02 to 0.05
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 2, err  # stderr is not a terminal: the first and the last state
    assert err[0].startswith(" 40%|") and "t = 0.0200/0.05 s" in err[0]
    assert err[1].startswith("100%|") and "t = 0.0500/0.05 s" in err[1]
    assert "dt 0.001 s" in err[1] and "steps/s" in err[1]


def test_run_without_duration_is_an_error(scene_dict):
    del scene_dict["duration"]
    sim = sphfluid.Simulation(scene_dict)
    with pytest.raises(ValueError, match="no duration"):
        sim.run()


def test_unused_terms_select_a_reduced_step(scene_dict):
    scene_dict["fluid"]["viscosity"] = 0.0
    scene_dict["walls"] = []
    assert sphfluid.Simulation(scene_dict)._solver.features == 0
    scene_dict["fluid"]["surface_tension"] = 1.0
    assert sphfluid.Simulation(scene_dict)._solver.features == 2


def test_walls_added_at_run_time_are_respected(scene_dict):
    # A lid over the tank, added while running: the fluid thrown up stays below it.
    scene_dict["fluid_regions"][0]["velocity"] = [0.0, 3.0]
    scene_dict["fluid"].update(gas_constant=20.0, viscosity=5.0)
    sim = sphfluid.Simulation(scene_dict)
    assert sim._solver.features & 4
    sim.add_wall((0.0, 0.6), (1.0, 0.6))
    assert len(sim.walls) == 4 and sim.scene.walls[-1] == ((0.0, 0.6), (1.0, 0.6))
    sim.run(0.3)
    assert sim.positions[:, 1].max() < 0.6
    sim.remove_wall(-1)
    assert len(sim.walls) == 3
    with pytest.raises(ValueError, match=r"walls\[3\]: wall segment has zero length"):
        sim.add_wall((0.5, 0.5), (0.5, 0.5))
    with pytest.raises(IndexError):
        sim.remove_wall(7)


def test_walls_can_appear_in_a_scene_without_any(scene_dict):
    scene_dict["walls"] = []
    scene_dict["fluid"].update(gas_constant=20.0, viscosity=5.0)  # a calm block
    sim = sphfluid.Simulation(scene_dict)
    assert sim._solver.features & 4 == 0
    sim.add_wall((-0.1, -0.02), (1.1, -0.02))  # a floor under the falling block
    assert sim._solver.features & 4
    sim.run(0.4)
    assert sim.positions[:, 1].min() > -0.02


def test_add_particles_gives_fresh_ids(scene_dict):
    sim = sphfluid.Simulation(scene_dict)
    n = sim.n_particles
    sim.add_particles([[0.7, 0.7], [0.8, 0.7], [5.0, 5.0]], [[0.0, -1.0]] * 3)
    assert sim.n_particles == n + 2  # the one outside the domain is dropped...
    assert sim.removed_particles == 1  # ...and counted
    assert sorted(sim.ids)[-2:] == [n, n + 1]
    sim.step(5)
    assert np.all(np.isfinite(sim.positions))


def test_compression_counts_only_densities_above_rho0():
    """stats()["max_compression"] is max(rho/rho0 - 1, 0); the density error
    |rho/rho0 - 1| also counts the free surface's shortfall. In the bundled
    hydrostatic column with wcsph's summed density (stiff), the surface falls
    far more short than the bottom is compressed."""
    scene = json.loads((ROOT / "scenes" / "hydrostatic.json").read_text())
    scene.setdefault("solver", {}).update(method="wcsph", density="summation")
    sim = sphfluid.Simulation(scene)
    sim.advance_to(0.05)
    st = sim.stats()
    dev = sim.densities / sim.scene.rest_density - 1.0
    assert st["max_compression"] == pytest.approx(max(dev.max(), 0.0), rel=1e-12)
    assert st["max_density_error"] == pytest.approx(np.abs(dev).max(), rel=1e-12)
    assert 0.0 < st["max_compression"] < 0.02
    assert st["max_density_error"] > 0.1


@pytest.mark.parametrize("method", ["seed", "wcsph"])
def test_a_held_view_keeps_the_state_it_showed(scene_dict, method):
    """Every array property is the state when it was read, however many steps
    (and sorts) follow, for the derived fields too."""
    if method == "wcsph":
        scene_dict["fluid"] = {"rest_density": 1000.0}
        scene_dict["solver"] = {"method": "wcsph", "time_step": "auto"}
    sim = sphfluid.Simulation(scene_dict, threads=1)
    sim.step(3)
    names = ("positions", "velocities", "accelerations", "densities", "pressures", "ids")
    views = {k: getattr(sim, k) for k in names}
    copies = {k: v.copy() for k, v in views.items()}
    for _ in range(5):
        sim.step(2)
        sim.compute_forces()
        for k in names:
            np.testing.assert_array_equal(views[k], copies[k], err_msg=k)
    assert not np.array_equal(sim.densities, copies["densities"])  # the run went on


def test_a_second_thread_changing_a_simulation_is_refused(scene_dict):
    """While one thread is inside run() (here held in its callback), another
    thread's step(), set_state() or save_state() raises RuntimeError and changes
    nothing; the run then ends as it would have alone."""
    import threading

    sim = sphfluid.Simulation(scene_dict, threads=1)
    alone = sphfluid.Simulation(scene_dict, threads=1)
    alone.run(0.01, every=0.005)
    inside, release = threading.Event(), threading.Event()

    def hold(s):
        inside.set()
        release.wait(30)

    worker = threading.Thread(target=sim.run, args=(0.01,), kwargs={"every": 0.005,
                                                                    "callback": hold})
    worker.start()
    try:
        assert inside.wait(30)
        steps = sim.step_count
        for call in (sim.step, lambda: sim.set_state(sim.positions, sim.velocities)):
            with pytest.raises(RuntimeError, match="being changed by another thread"):
                call()
        assert sim.step_count == steps
    finally:
        release.set()
        worker.join(30)
    assert (sim.time, sim.step_count) == (alone.time, alone.step_count)
    np.testing.assert_array_equal(sim.positions, alone.positions)
    sim.step()  # free again


def test_fresh_ids_that_would_overflow_are_refused(scene_dict):
    sim = sphfluid.Simulation(scene_dict)
    n = sim.n_particles
    top = np.iinfo(np.int64).max
    sim.set_state(sim.positions, sim.velocities, ids=np.arange(n, dtype=np.int64) + (top - n + 1))
    with pytest.raises(ValueError, match=r"no fresh ids left: the largest id in use is "
                                         + str(top)):
        sim.add_particles([[0.7, 0.7]])
    assert sim.n_particles == n  # nothing added


def test_a_wall_far_longer_than_the_domain_keeps_its_lookup_grid_small(scene_dict):
    # The lookup grid was coarsened by area only: a wall 1e10 m long and 2 h
    # high asked for ~1e9 cells (24 GB). Now it stays within its cell bound.
    import resource

    sim = sphfluid.Simulation(scene_dict)
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB
    sim.set_walls([((-1e10, -0.05), (1e10, -0.05))])
    sim.step(2)
    grown = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before
    assert grown < 500_000, f"{grown / 1e6:.1f} GB more"
    assert len(sim.walls) == 1
    sim.set_walls([((0.0, -0.05), (9e307, -0.05))])  # its area's cell count overflows
    sim.step(2)
    with pytest.raises(ValueError, match="longer than a double can hold"):
        sim.set_walls([((-9e307, -0.05), (9e307, -0.05))])


def test_a_particle_flying_at_1e300_meets_the_walls_without_undefined_casts(scene_dict):
    # The path's cells were converted to ints before clamping (UBSan: a signed
    # overflow); the sanitizer job runs this test.
    sim = sphfluid.Simulation(scene_dict)
    vel = np.array(sim.velocities)
    vel[0] = (1e300, -1e300)
    sim.set_state(sim.positions, vel)
    with pytest.raises(sphfluid.InstabilityError):
        sim.step(3)
