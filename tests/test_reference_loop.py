"""The plain reference loop (benchmarks/reference_loop.cpp) computes the seed's
physics: its densities and accelerations after one evaluation equal the brute-force
sums of tests/reference.py to round-off. Needs a C++ compiler with OpenMP."""
from __future__ import annotations

import numpy as np
import pytest
from conftest import benchmark_module
from reference import seed_forces

loop = benchmark_module("reference_loop.py")

PARAMS = {"h": 0.1, "mass": 0.5, "rho0": 100.0, "k": 30.0, "eta": 0.4}


def brute_force(x, v, gravity):
    """tests/reference.py's seed sums (m for mass): densities, accelerations."""
    p = dict(PARAMS)
    rho, _, a = seed_forces(x, v, m=p.pop("mass"), gravity=gravity, **p)
    return rho, a


@pytest.fixture(scope="module")
def binary():
    try:
        return loop.build()
    except loop.ReferenceLoopError as exc:
        pytest.skip(f"reference loop: {exc}")


def jittered_block(n_side: int, dx: float, seed: int = 3):
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(n_side), np.arange(n_side))
    x = (np.column_stack([i.ravel(), j.ravel()]) + 0.5) * dx
    x += rng.uniform(-0.3 * dx, 0.3 * dx, x.shape)
    v = rng.normal(0.0, 1.0, x.shape)
    return x, v


@pytest.mark.parametrize("threads", [1, 2])
def test_density_and_acceleration_equal_the_brute_force_sums(binary, threads):
    x, v = jittered_block(14, 0.045)  # about 14 neighbours each, cells straddled
    x += (-0.37, 1.21)  # a bounding box away from the origin
    rho, a = loop.evaluate(binary, x, v, gx=0.0, gy=-9.81, tank=0.0, threads=threads,
                           **PARAMS)
    rho_ref, a_ref = brute_force(x, v, (0.0, -9.81))
    np.testing.assert_allclose(rho, rho_ref, rtol=1e-12)
    scale = np.abs(a_ref - (0.0, -9.81)).max()
    assert scale > 1.0  # pressure and viscosity at work, not gravity alone
    np.testing.assert_allclose(a, a_ref, rtol=0, atol=1e-11 * scale)


def test_an_isolated_pair_and_a_lone_particle(binary):
    """Beyond h nothing is felt; within h the pair's forces are equal and opposite."""
    x = np.array([[0.0, 0.0], [0.06, 0.0], [1.0, 1.0]])
    v = np.zeros_like(x)
    rho, a = loop.evaluate(binary, x, v, gx=0.0, gy=0.0, tank=0.0, **PARAMS)
    rho_ref, a_ref = brute_force(x, v, (0.0, 0.0))
    np.testing.assert_allclose(rho, rho_ref, rtol=1e-12)
    np.testing.assert_allclose(a, a_ref, rtol=1e-12, atol=1e-12)
    assert a[0, 0] != 0 and a[0, 0] == pytest.approx(-a[1, 0]) and a[0, 1] == 0
    assert rho[2] == pytest.approx(PARAMS["mass"] * 4 / (np.pi * PARAMS["h"] ** 2))
    assert np.all(a[2] == 0.0)


def test_it_runs_the_dam_break_and_reports_steps_per_second(binary, tmp_path):
    from sphfluid import _core, load_scene
    from sphfluid.bench import dam_break_scene
    from sphfluid.dam_break import GEOMETRY

    scene = load_scene(dam_break_scene(300))
    x, v = scene.lattice_points()
    mass = _core.kernels.lattice_mass(scene.rest_density, scene.spacing, scene.smoothing_length)
    source = loop.write_input(
        tmp_path / "in.txt", x, v, mass=mass, h=scene.smoothing_length, k=scene.gas_constant,
        rho0=scene.rest_density, eta=scene.viscosity, gx=0.0, gy=-GEOMETRY.g,
        tank=GEOMETRY.tank, dt=scene.time_step, warmup=2, steps=20, threads=1)
    assert loop.run(binary, source) > 0
    with pytest.raises(loop.ReferenceLoopError, match="missing steps"):
        text = source.read_text().replace("steps ", "stepz ")
        (tmp_path / "bad.txt").write_text(text)
        loop.run(binary, tmp_path / "bad.txt")


def test_bench_prints_our_speed_as_a_multiple_of_the_reference(binary, capsys):
    from sphfluid.cli import main

    assert main(["bench", "--particles", "300", "--steps", "3", "--warmup", "1", "--threads",
                 "1", "--repeat", "2", "--pair-precision", "double,float"]) == 0
    out, err = capsys.readouterr()
    assert "Reference loop (`benchmarks/reference_loop.cpp`" in out
    line = next(x for x in out.splitlines() if x.startswith("- 1 thread: reference "))
    assert "ours ÷ reference: double " in line and ", float" in line
    assert err.count("1 thread(s), reference loop: ") == 2  # once a round


def test_bench_without_the_benchmarks_folder_notes_it_and_carries_on(tmp_path, capsys):
    from sphfluid.cli import main

    assert main(["bench", "--particles", "300", "--steps", "2", "--warmup", "1", "--threads",
                 "1", "--repeat", "1", "--benchmarks-dir", str(tmp_path / "none")]) == 0
    out, err = capsys.readouterr()
    assert "| 1 | double |" in out and "Reference loop" not in out
    notes = [x for x in err.splitlines() if x.startswith("note: no reference loop")]
    assert len(notes) == 1 and "is not a folder" in notes[0]


def test_the_ratio_is_the_median_of_each_rounds_ratio():
    from sphfluid.bench import Plan, reference_lines

    plan = Plan(1000, 10, 1, 3, "seed", (2,), ("double",), 0.0)
    ours = [{"steps_per_s": v, "wall": 10 / v, "pairs": "double", "pairs_ran": "double"}
            for v in (100.0, 200.0, 300.0)]
    text = reference_lines(plan, {("double", 2): ours}, {2: [100.0, 50.0, 300.0]}, "`c++`")
    # rounds' ratios 1, 4, 1: median 1 (the ratio of the medians would say 2)
    assert "- 2 threads: reference 100 steps/s (50–300); ours ÷ reference: double 1.00" in text
