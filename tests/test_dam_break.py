"""The dam break's geometry, defined once (sphfluid.dam_break): the scenes that the
bench and the validation build from it are the ones they built before it existed
(frozen copies below), and scenes/dam_break.json agrees with it."""
from __future__ import annotations

import json

import pytest
from conftest import ROOT
from sphfluid import load_scene
from sphfluid.bench import dam_break_scene, variant_scene
from sphfluid.dam_break import GEOMETRY
from sphfluid.validation.cases import CASES

_DOMAIN = {"min": [-0.1, -0.1], "max": [4.1, 3.6]}
_COLUMN = [{"shape": "rectangle", "min": [0.0, 0.0], "max": [1.0, 2.0]}]
_WALLS = [{"polyline": [[0.0, 3.0], [0.0, 0.0], [4.0, 0.0], [4.0, 3.0]]}]
_SEED_FLUID = {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 30.0}


def _frozen(name, fluid, dx, solver, **extra):
    return {"format": "sphfluid-scene/1", "name": name, "gravity": [0.0, -9.81],
            "domain": _DOMAIN, "fluid": fluid,
            "resolution": {"spacing": dx},
            "fluid_regions": _COLUMN, "walls": _WALLS, "solver": solver, **extra}


# What bench.dam_break_scene and the validation's DamBreak.scene returned before the
# geometry was defined in one place (printed from that code, floats as repr), since
# each method takes its default support (wcsph's fixed step 0.3 (h/2) / c0 with it).
FROZEN = {
    ("bench", 1000, "seed"): _frozen(
        "Dam break, 1,000 particles", _SEED_FLUID, 0.044721359549995794,
        {"method": "seed", "time_step": 0.00044721359549995795}),
    ("bench", 10000, "wcsph"): _frozen(
        "Dam break, 10,000 particles", _SEED_FLUID, 0.01414213562373095,
        {"method": "wcsph", "time_step": 9.914443968959147e-05}),
    ("validation", 10, "seed"): _frozen(
        "validation: dam break", _SEED_FLUID, 0.1,
        {"method": "seed", "time_step": "auto", "cfl": 0.4}, duration=0.72),
    ("validation", 20, "wcsph"): _frozen(
        "validation: dam break", {"rest_density": 1000.0}, 0.05,
        {"method": "wcsph", "time_step": "auto", "cfl": 0.4}, duration=0.72),
}


@pytest.mark.parametrize("key", list(FROZEN), ids=lambda k: "-".join(map(str, k)))
def test_bench_and_validation_scenes_are_unchanged(key):
    user, n, method = key
    built = dam_break_scene(n, method) if user == "bench" else CASES["dam_break"].scene(n, method)
    assert built == FROZEN[key]
    assert json.dumps(built) == json.dumps(FROZEN[key])  # the same keys in the same order


def test_seed_float_variant_only_adds_the_precision():
    scene = variant_scene(1000, "seed-float")
    assert scene.pop("solver") == {"method": "seed", "time_step": 0.00044721359549995795,
                                   "pair_precision": "float"}
    frozen = dict(FROZEN[("bench", 1000, "seed")])
    del frozen["solver"]
    assert scene == frozen


def test_the_bundled_scene_file_agrees_with_the_definition():
    d = json.loads((ROOT / "scenes" / "dam_break.json").read_text())
    built = GEOMETRY.scene(d["resolution"]["spacing"], name=d["name"], fluid=d["fluid"],
                           solver=d["solver"], duration=d["duration"])
    for key in ("gravity", "domain", "fluid_regions", "walls"):
        assert d[key] == built[key], key
    assert d["fluid"]["rest_density"] == GEOMETRY.rho0
    scene = load_scene(d)
    assert scene.spacing == built["resolution"]["spacing"]
    assert scene.smoothing_length == load_scene(built).smoothing_length
    assert scene.domain_min == GEOMETRY.domain_min and scene.domain_max == GEOMETRY.domain_max


def test_the_geometry_is_consistent():
    """The column stands on the floor against the left wall, inside the tank, and
    the domain holds the tank."""
    g = GEOMETRY
    (x0, y0), (x1, y1) = g.column()["min"], g.column()["max"]
    assert (x0, y0) == (0.0, 0.0) and x1 == g.a and y1 == 2 * g.a
    assert x1 < g.tank and y1 < g.tank_height
    xs = [p[0] for p in g.walls()[0]["polyline"]]
    ys = [p[1] for p in g.walls()[0]["polyline"]]
    assert (min(xs), max(xs), min(ys), max(ys)) == (0.0, g.tank, 0.0, g.tank_height)
    assert g.domain_min[0] < 0 < g.tank < g.domain_max[0]
    assert g.domain_min[1] < 0 < g.tank_height < g.domain_max[1]
