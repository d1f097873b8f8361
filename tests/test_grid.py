"""Cell grid and neighbour list: the same pairs as a brute-force search, at cell
and domain edges too, and re-sorting leaves every observable unchanged."""
from __future__ import annotations

import numpy as np
import pytest
from reference import seed_forces
from sphfluid import _core


def make_solver(x, v=None, *, h=0.1, walls=None, eta=0.0, sigma=0.0, threads=0,
                lo=(-1.0, -1.0), hi=(2.0, 2.0), guard=True):
    p = _core.SimParams()
    p.h, p.mass, p.rho0, p.k, p.eta, p.sigma = h, 0.5, 100.0, 30.0, eta, sigma
    p.guard = guard
    p.domain_min, p.domain_max = lo, hi
    p.threads = threads
    v = np.zeros_like(x) if v is None else v
    return _core.Solver(p, x, v, np.zeros((0, 2, 2)) if walls is None else walls)


def brute_force_pairs(x, h):
    d2 = ((x[:, None, :] - x[None, :, :]) ** 2).sum(-1)
    return int((d2 < h * h).sum() - len(x))


def test_pairs_equal_brute_force_on_random_cloud():
    rng = np.random.default_rng(11)
    x = rng.uniform(0.0, 1.0, (700, 2))
    s = make_solver(x)
    assert s.neighbour_pairs == brute_force_pairs(x, 0.1)


def test_pairs_at_cell_edges_and_exactly_h_apart():
    # A lattice of spacing h/2 starting on a cell boundary: many pairs lie exactly
    # at distance h (not neighbours: r < h is required) and on cell edges.
    h = 0.1
    g = np.arange(12) * (h / 2)
    X, Y = np.meshgrid(g, g)
    x = np.c_[X.ravel(), Y.ravel()]
    s = make_solver(x, h=h)
    assert s.neighbour_pairs == brute_force_pairs(x, h)


def test_pairs_just_under_h_apart_in_cells_two_apart_by_rounding():
    # Cell coordinates 90.99999999999999 and 92.0 (h = 0.02, the grid starting
    # at x = -1): the cells are computed as two apart though the pair is closer
    # than h; cells a hair larger than h keep such a pair one cell apart.
    x = np.array([[-1.0, 0.0], [0.8199999999999998, 0.0], [0.8399999999999997, 0.0]])
    assert 0.8399999999999997 - 0.8199999999999998 < 0.02
    s = make_solver(x, h=0.02, lo=(-1.5, -1.0), hi=(1.5, 1.0))
    assert s.neighbour_pairs == brute_force_pairs(x, 0.02) == 2


def test_pair_count_spans_blocks_and_outlives_removal():
    # Several pair blocks (an even number from 1,025 particles on: four here);
    # then a step in which particles leave the domain: the count stays that of
    # the evaluation.
    rng = np.random.default_rng(3)
    x = rng.uniform(0.0, 1.5, (3000, 2))
    v = np.zeros_like(x)
    v[:200, 0] = 400.0  # out of the domain in one step
    s = make_solver(x, v, lo=(-0.5, -0.5), hi=(2.0, 2.0), guard=False)  # a crowd, not a fluid
    assert s.neighbour_pairs == brute_force_pairs(x, 0.1)
    before = s.neighbour_pairs
    s.step(0.01)
    assert s.n_particles < len(x)
    assert s.neighbour_pairs == before


def test_pairs_at_domain_edges():
    # Particles sitting exactly on the domain boundary are kept and found.
    lo, hi = (0.0, 0.0), (1.0, 0.5)
    x = np.array([[0.0, 0.0], [0.05, 0.0], [1.0, 0.5], [0.95, 0.5], [1.0, 0.45], [0.0, 0.5]])
    s = make_solver(x, lo=lo, hi=hi)
    assert s.n_particles == len(x)
    assert s.neighbour_pairs == brute_force_pairs(x, 0.1)


def test_densities_equal_brute_force_with_coincident_particles():
    rng = np.random.default_rng(5)
    x = rng.uniform(0.0, 0.5, (300, 2))
    x[10] = x[20]  # two particles at the same point
    s = make_solver(x)
    order = np.argsort(s.ids)
    rho, _, _ = seed_forces(x, np.zeros_like(x), h=0.1, m=0.5, rho0=100.0, k=30.0)
    np.testing.assert_allclose(s.densities[order], rho, rtol=1e-12)
    assert np.all(np.isfinite(s.accelerations))


def by_id(s):
    o = np.argsort(s.ids)
    return {name: getattr(s, name)[o].copy()
            for name in ("positions", "velocities", "accelerations", "densities", "pressures")}


def test_storage_is_sorted_by_cell_and_ids_follow_particles():
    rng = np.random.default_rng(2)
    x = rng.uniform(0.0, 1.0, (500, 2))
    s = make_solver(x)
    # After the sort the stored order differs from the input order...
    assert not np.array_equal(s.ids, np.arange(len(x)))
    # ...but each id still carries its own position.
    np.testing.assert_array_equal(s.positions[np.argsort(s.ids)], x)


def cells_of(x, h):
    """The cell of each position as CellGrid::sort computes it (grid.cpp): cells
    a hair wider than h, on a lattice fixed in space, over the bounding box."""
    w = h * (1 + 1e-8)
    inv = 1 / w
    lo = np.floor(x.min(axis=0) * inv) * w
    nx, ny = (np.floor((x.max(axis=0) - lo) * inv) + 1).astype(int)
    ix = np.clip(np.trunc((x[:, 0] - lo[0]) * inv).astype(int), 0, nx - 1)
    iy = np.clip(np.trunc((x[:, 1] - lo[1]) * inv).astype(int), 0, ny - 1)
    return iy * nx + ix


@pytest.mark.parametrize("threads", [1, 2])
def test_every_sort_gives_the_stable_counting_order(threads):
    # A jittered lattice in a walled box, stirred at random: from one step to
    # the next no particle changes cell, or a few do and the sort moves just
    # those into place (on 2 threads each its own part of the particles), or
    # so many do (every tenth step is 20 times as long) that it permutes them
    # all (measured on this scene: 11, 63 and 17 of the 91 sorts). Either way
    # the stored order must be the stable counting sort's: by cell, the
    # particles of a cell in their order before the sort.
    rng = np.random.default_rng(17)
    h = 0.05
    g = (np.arange(40) + 0.5) * (h / 2)
    X, Y = np.meshgrid(g, g)
    x = np.c_[X.ravel(), Y.ravel()] + rng.uniform(-0.2, 0.2, (1600, 2)) * h / 2
    v = rng.normal(0.0, 1.0, x.shape)
    box = np.array([[[0, 0], [1, 0]], [[1, 0], [1, 1]], [[1, 1], [0, 1]], [[0, 1], [0, 0]]],
                   dtype=float)
    s = make_solver(x, v, h=h, walls=box, guard=False, threads=threads)
    for k in range(90):
        ids, before = s.ids.copy(), s.positions.copy()
        s.step(2e-3 if k % 10 == 9 else 1e-4)
        expected = ids[np.argsort(cells_of(before, h), kind="stable")]
        np.testing.assert_array_equal(s.ids, expected, err_msg=f"step {k + 1}")
    counts = s.sort_counts
    assert counts["unchanged"] >= 4 and counts["moved"] >= 15 and counts["permuted"] >= 10, counts
    # On 2 threads the moves are cut into parts, one a thread, where the
    # particles before a place stay among themselves.
    assert counts["moved_in_parts"] >= (10 if threads == 2 else 0), counts


def test_resorting_leaves_observables_unchanged():
    rng = np.random.default_rng(9)
    x = rng.uniform(0.0, 1.0, (400, 2))
    v = rng.normal(0.0, 1.0, (400, 2))
    a = make_solver(x, v, eta=0.3, sigma=0.2)
    # The same particles given in a shuffled order, with the same ids.
    perm = rng.permutation(len(x))
    b = make_solver(x[perm], v[perm], eta=0.3, sigma=0.2)
    b.set_state(x[perm], v[perm], perm)
    ra, rb = by_id(a), by_id(b)
    for name in ra:
        np.testing.assert_allclose(ra[name], rb[name], rtol=1e-12, atol=1e-12, err_msg=name)
    # Re-evaluating (which re-sorts) changes nothing either.
    a.compute_forces()
    for name, value in by_id(a).items():
        np.testing.assert_allclose(value, ra[name], rtol=1e-12, atol=1e-12, err_msg=name)


@pytest.mark.parametrize("n", [3_000, 60_000])
def test_parallel_sort_gives_the_serial_order(n):
    """From 1,000 particles the counting sort runs on the threads; its order
    (and so every result) must be the serial one."""
    rng = np.random.default_rng(17)
    x = rng.uniform(0.0, 3.0, (n, 2))
    runs = []
    for threads in (1, 2):
        p = _core.SimParams()
        p.h, p.mass, p.rho0, p.k = 0.03, 0.001, 1.0, 1.0
        p.domain_min, p.domain_max = (-1.0, -1.0), (4.0, 4.0)
        p.threads = threads
        s = _core.Solver(p, x, np.zeros_like(x), np.zeros((0, 2, 2)))
        runs.append((s.ids.copy(), s.densities.copy()))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert np.array_equal(runs[0][1], runs[1][1])
    # cell-major, and stable: within a cell the input order is kept
    assert not np.array_equal(runs[0][0], np.arange(n))
