"""Storage order is an implementation detail: the same particles given in any
order give the same observables, particle by particle (by id), to round-off."""
from __future__ import annotations

import numpy as np
import pytest
from sphfluid import _core


def params(method, periodic=False):
    p = _core.SimParams()
    p.method = getattr(_core.Method, method)
    p.h, p.mass, p.rho0, p.k, p.c0, p.alpha = 0.1, 0.6, 1000.0, 30.0, 20.0, 0.2
    p.eta, p.sigma = 0.3, 0.5
    p.domain_min, p.domain_max = (-0.2, -0.2), (0.9, 0.9)
    p.periodic = (periodic, False)
    return p


@pytest.mark.parametrize("method", ["seed", "wcsph"])
@pytest.mark.parametrize("periodic", [False, True])
def test_shuffled_input_gives_the_same_run(method, periodic):
    rng = np.random.default_rng(21)
    n = 400
    x = rng.uniform(0.05, 0.65, (n, 2))
    v = rng.normal(0.0, 0.3, (n, 2))
    ids = np.arange(n)
    walls = np.array([[[0.0, 0.0], [0.7, 0.0]], [[0.0, 0.7], [0.0, 0.0]]])
    perm = rng.permutation(n)
    a = _core.Solver(params(method, periodic), x, v, walls, ids)
    b = _core.Solver(params(method, periodic), x[perm], v[perm], walls, ids[perm])
    a.step(2e-4, 30)
    b.step(2e-4, 30)
    oa, ob = np.argsort(a.ids), np.argsort(b.ids)
    assert np.array_equal(a.ids[oa], b.ids[ob])
    for field in ("positions", "velocities", "accelerations", "densities", "pressures"):
        fa, fb = getattr(a, field)[oa], getattr(b, field)[ob]
        scale = np.abs(fa).max()
        np.testing.assert_allclose(fb, fa, rtol=0, atol=1e-11 * scale, err_msg=field)
    # the two really were stored in different orders at the start
    assert not np.array_equal(perm, np.arange(n))
