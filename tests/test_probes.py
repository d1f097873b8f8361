"""Measurement probes: the scene's "probes", their values against the hydrostatic
tank, and probes.csv of `sphfluid run --out`."""
from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest
import sphfluid
from conftest import ROOT
from sphfluid import probes as pr
from sphfluid.metadata import scene_hash
from sphfluid.cli import main
from sphfluid.simulation import Simulation

TANK = json.loads((ROOT / "scenes" / "water" / "hydrostatic.json").read_text())
H = 1.0  # the tank's fill height, m
RHO0, G = 1000.0, 9.81
# the tank's polyline: segment 0 the left wall, 1 the floor, 2 the right wall
TANK_PROBES = {
    "points": [{"name": "low", "at": [0.5, 0.025]}, {"name": "mid", "at": [0.5, 0.25]},
               {"name": "high", "at": [0.3, 0.75]}, {"name": "air", "at": [0.5, 1.3]}],
    "surface": [{"name": "h_mid", "x": 0.5}, {"name": "h_side", "x": 0.05},
                {"name": "h_out", "x": 1.05}],
    "walls": [{"name": "floor", "segments": [1]}, {"name": "left", "segments": [0]},
              {"name": "tank", "segments": [0, 1, 2]}],
}


def tank(probes=None) -> dict:
    d = copy.deepcopy(TANK)
    d["probes"] = copy.deepcopy(probes if probes is not None else TANK_PROBES)
    return d


@pytest.fixture(scope="module")
def at_rest():
    """The water tank after 0.5 s, and its probes' values."""
    sim = Simulation(tank())
    sim.advance_to(0.5)
    return sim, pr.sample(sim)


# --------------------------------------------------------------------------- the scene

def test_probes_load_and_round_trip():
    scene = sphfluid.load_scene(tank({**TANK_PROBES, "every": 0.02}))
    assert [p.name for p in scene.probes.points] == ["low", "mid", "high", "air"]
    assert scene.probes.walls[2].segments == (0, 1, 2) and scene.probes.every == 0.02
    again = sphfluid.load_scene(json.loads(json.dumps(scene.to_dict())))
    assert again == scene and again.probes == scene.probes
    assert sphfluid.load_scene(TANK).probes is None
    assert "probes" not in sphfluid.load_scene(TANK).to_dict()


@pytest.mark.parametrize("probes, problem", [
    ({"pionts": []}, 'probes.pionts: unknown key (did you mean "points"?)'),
    ({"points": [{"name": "a", "at": [0.5, 2.0]}]}, "probes.points[0].at: [0.5, 2.0] is "
     "outside the domain"),
    ({"points": [{"name": "a", "at": [0.5]}]}, "probes.points[0].at: expected [x, y]"),
    ({"points": [{"at": [0.5, 0.5]}]}, "probes.points[0].name: required key is missing"),
    ({"points": [{"name": "a", "at": [0.5, 0.5]}], "surface": [{"name": "a", "x": 0.5}]},
     'probes.surface[0].name: "a" is already the name of probes.points[0]'),
    ({"points": [{"name": "a,b", "at": [0.5, 0.5]}]}, "probes.points[0].name: expected a "
     "name with no commas, quotes or line breaks"),
    ({"surface": [{"name": "s", "x": 2.0}]}, "probes.surface[0].x: 2 is outside the domain"),
    ({"walls": [{"name": "w", "segments": [3]}]}, "probes.walls[0].segments[0]: no segment 3: "
     "the walls have 3 segment(s)"),
    ({"walls": [{"name": "w", "segments": [1, 1]}]}, "probes.walls[0].segments: lists 1 more "
     "than once"),
    ({"walls": [{"name": "w", "segments": [0.5]}]}, "probes.walls[0].segments[0]: expected an "
     "integer, got the number 0.5"),
    ({"walls": [{"name": "w", "segments": []}]}, "probes.walls[0].segments: expected a "
     "non-empty list"),
    ({"points": [{"name": "a", "at": [0.5, 0.5]}], "every": 0}, "probes.every: must be > 0"),
    ({}, "probes: has no probe"),
    ([], "probes: expected an object"),
])
def test_bad_probes_are_refused_with_their_json_path(probes, problem):
    with pytest.raises(sphfluid.SceneError) as e:
        sphfluid.load_scene(tank(probes))
    assert any(p.startswith(problem) for p in e.value.problems), e.value.problems


# --------------------------------------------------------------------------- the values

def test_kernel_is_the_wendland_c2_and_sums_to_one_on_the_lattice():
    from reference import wendland

    h = 0.075
    r = np.linspace(0.0, 0.1, 41)
    np.testing.assert_allclose(pr.wendland(r, h), wendland(r, h), rtol=1e-14, atol=0)
    dx = 0.025
    i = np.arange(-5, 6)
    x, y = np.meshgrid(i * dx, i * dx)
    assert (pr.wendland(np.hypot(x, y), h) * dx * dx).sum() == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("name", ["low", "mid", "high"])
def test_point_pressure_in_the_tank_at_rest_is_hydrostatic(at_rest, name):
    """rho0 g (H - y), within 1 % of rho0 g H (measured at t = 0.5 s: under 0.2 %; the
    tank's acoustic sloshing moves it by about 1 % between frames). A point one spacing
    deeper or shallower is 2.5 % off; "low", one spacing above the floor, is 10 % low
    without the Shepard normalisation (its kernel sum is 0.9)."""
    sim, values = at_rest
    probe = next(p for p in sim.scene.probes.points if p.name == name)
    expected = RHO0 * G * (H - probe.at[1])
    assert abs(values[f"{name}.p"] - expected) < 0.01 * RHO0 * G * H
    assert values[f"{name}.rho"] == pytest.approx(RHO0, rel=0.01)
    assert abs(values[f"{name}.u"]) < 0.01 and abs(values[f"{name}.v"]) < 0.01


def test_point_in_air_is_nan(at_rest):
    _, values = at_rest
    assert all(math.isnan(values[f"air.{q}"]) for q in ("p", "u", "v", "rho"))


def test_surface_height_is_the_fill_height(at_rest):
    """Within a quarter of a spacing (measured: 1e-4 m); NaN on a line with no fluid."""
    sim, values = at_rest
    dx = sim.scene.spacing
    assert values["h_mid.height"] == pytest.approx(H, abs=dx / 4)
    assert values["h_side.height"] == pytest.approx(H, abs=dx / 4)  # beside the wall
    assert math.isnan(values["h_out.height"])


def test_floor_force_is_the_weight_of_the_water(at_rest):
    """The floor carries the weight per metre, m n g, downwards: within 1.5 %
    (measured at t = 0.5 s: 0.03 %; the sloshing moves it by about 1.3 %). The left
    wall is pushed outwards by rho0 g H^2 / 2; the tank as a whole, by the weight."""
    sim, values = at_rest
    weight = sim.particle_mass * sim.n_particles * G
    assert values["floor.fy"] == pytest.approx(-weight, rel=0.015)
    assert abs(values["floor.fx"]) < 1e-6 * weight
    assert values["left.fx"] == pytest.approx(-RHO0 * G * H**2 / 2, rel=0.02)
    assert abs(values["left.fy"]) < 1e-6 * weight
    assert values["tank.fy"] == pytest.approx(values["floor.fy"], rel=1e-12)
    assert abs(values["tank.fx"]) < 1e-3 * weight


def test_wall_force_counts_the_fluid_on_both_sides():
    """A plate across the middle of a tank full on both sides feels no net force; with
    the water on one side, the force points away from it."""
    d = tank({"walls": [{"name": "plate", "segments": [3]}]})
    d["walls"].append([[0.2, 0.5], [0.8, 0.5]])
    sim = Simulation(d)
    values = pr.sample(sim)
    assert abs(values["plate.fy"]) < 0.02 * RHO0 * G * 0.5 * 0.6
    one_side = pr.sample(sim, pr.Probes(walls=(pr.WallProbe("floor", (1,)),)))
    assert one_side["floor.fy"] < 0
    assert set(one_side) == {"time", "floor.fx", "floor.fy", "floor.fx_viscous",
                             "floor.fy_viscous"}


class _Particles:
    """What probes._Field reads of a simulation, for made-up particles."""

    def __init__(self, pos, vel, h, dx):
        self.positions, self.velocities = pos, vel
        self.densities = np.full(len(pos), RHO0)
        self.pressures = np.zeros(len(pos))
        self.particle_mass = RHO0 * dx * dx
        self.smoothing_length = h


@pytest.mark.parametrize("u_wall", [0.0, 0.4])
def test_wall_slope_is_exact_for_a_quadratic_profile(u_wall):
    """Particles on the lattice above the wall y = 0 (moving at u_wall) with
    u = u_wall + 0.3 s - 2 s^2: the fit's slope at the wall is 0.3, on either
    orientation of the segment; the side with no particles gives NaN."""
    dx, h = 0.02, 0.06
    g = (np.arange(-20, 20) + 0.5) * dx
    x, y = np.meshgrid(g, g[20:])
    pos = np.column_stack([x.ravel(), y.ravel()])
    s = pos[:, 1]
    vel = np.column_stack([u_wall + 0.3 * s - 2 * s * s, np.zeros(len(s))])
    field = pr._Field(_Particles(pos, vel, h, dx))
    stations = np.column_stack([np.linspace(-0.2, 0.2, 9), np.zeros(9)])
    up, along = np.array([0.0, 1.0]), np.array([1.0, 0.0])
    wall = np.array([u_wall, 0.0])
    np.testing.assert_allclose(pr._wall_slopes(field, stations, up, along, wall), 0.3,
                               rtol=1e-9)
    np.testing.assert_allclose(pr._wall_slopes(field, stations, up, -along, wall), -0.3,
                               rtol=1e-9)
    assert np.isnan(pr._wall_slopes(field, stations, -up, along, wall)).all()
    # the force on the wall's stretch: eta 0.3 per metre, along +x (dragged with the flow)
    forces = pr._wall_force(field, np.array([[[-0.2, 0.0], [0.2, 0.0]]]), wall[None], 2.0, dx)
    assert forces[2] == pytest.approx(2.0 * 0.3 * 0.4, rel=1e-9) and forces[3] == 0.0


def test_viscous_wall_force_of_poiseuille_flow_is_the_analytic_shear():
    """Steady plane Poiseuille flow (the validation case, n = 10, t = 1 s): the
    shear on each plate is rho F L / 2 per unit area (measured: 2.0 % over)."""
    from sphfluid.validation.cases import CASES

    case = CASES["poiseuille"]
    sim = Simulation(sphfluid.load_scene(case.scene(10, "wcsph")))
    sim.advance_to(1.0)
    field = pr._Field(sim)
    width, L = 10 * sim.scene.spacing, case.length
    tau = case.rho0 * case.force * L / 2
    for y in (0.0, L):
        wall = np.array([[[0.0, y], [width, y]]])
        fx, fy, vx, vy = pr._wall_force(field, wall, np.zeros((1, 2)), sim.scene.viscosity,
                                        sim.scene.spacing)
        assert vx == pytest.approx(tau * width, rel=0.03) and abs(vy) < 1e-6 * abs(vx)


def test_sample_is_deterministic_and_leaves_the_state_alone(at_rest):
    sim, values = at_rest
    before = sim.positions.copy()
    again = pr.sample(sim)
    assert json.dumps(again) == json.dumps(values)
    np.testing.assert_array_equal(sim.positions, before)
    assert list(again) == ["time", *sim.scene.probes.columns()]


# --------------------------------------------------------------------------- probes.csv

def run(tmp_path, scene: dict, *args, out="out") -> int:
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(scene))
    return main(["run", str(path), "--out", str(tmp_path / out), "--quiet", *map(str, args)])


def test_csv_has_the_metadata_the_columns_and_a_row_per_probe_time(tmp_path, capsys):
    probes = {**TANK_PROBES, "every": 0.05}
    assert run(tmp_path, tank(probes), "--duration", 0.2, "--every", 0.1) == 0
    assert "probes              5 rows" in capsys.readouterr().out
    text = (tmp_path / "out" / "probes.csv").read_text()
    assert text.startswith("# sphfluid probes: {")
    meta, columns, rows = pr.read_csv(tmp_path / "out" / "probes.csv")
    scene = sphfluid.load_scene(tank(probes))
    assert meta["metadata"]["scene_hash"] == scene_hash(scene)
    assert meta["metadata"]["method"] == "wcsph" and meta["every"] == 0.05
    assert meta["probes"] == scene.probes.to_dict()
    assert columns == ["time", "low.p", "low.u", "low.v", "low.rho", "mid.p", "mid.u", "mid.v",
                       "mid.rho", "high.p", "high.u", "high.v", "high.rho", "air.p", "air.u",
                       "air.v", "air.rho", "h_mid.height", "h_side.height", "h_out.height",
                       *(f"{w}.{q}" for w in ("floor", "left", "tank")
                         for q in ("fx", "fy", "fx_viscous", "fy_viscous"))]
    # t = 0, then the first 25-step sample at or past 0.05 and 0.15, and the landings
    # on the frames at 0.1 and 0.2
    assert rows.shape == (5, len(columns))
    t = rows[:, 0]
    assert t[0] == 0 and t[2] == pytest.approx(0.1, abs=1e-12) and t[4] == pytest.approx(0.2)
    assert 0.05 <= t[1] < 0.06 and 0.15 <= t[3] < 0.16
    assert np.isnan(rows[:, columns.index("air.p")]).all()
    assert rows[:, columns.index("floor.fy")] == pytest.approx(-9810.0, rel=0.03)


def test_probes_do_not_change_the_run(tmp_path):
    """Rows between the frames are written at the run's own samples: the final state
    is bit for bit the state without probes."""
    assert run(tmp_path, TANK, "--duration", 0.1, "--every", 0.05, out="plain") == 0
    assert run(tmp_path, tank({**TANK_PROBES, "every": 0.02}), "--duration", 0.1,
               "--every", 0.05, out="probed") == 0
    assert not (tmp_path / "plain" / "probes.csv").exists()
    a = np.load(tmp_path / "plain" / "frame_00002.npz")
    b = np.load(tmp_path / "probed" / "frame_00002.npz")
    for key in ("time", "positions", "velocities", "densities", "ids"):
        np.testing.assert_array_equal(a[key], b[key])
    _, _, rows = pr.read_csv(tmp_path / "probed" / "probes.csv")
    # t = 0, the first 25-step sample (about 0.008 s apart) at or past 0.02, 0.04,
    # 0.06 and 0.08, and the end
    assert len(rows) == 6
    k = np.arange(6)
    assert (rows[:, 0] >= 0.02 * k - 1e-12).all() and (rows[:, 0] < 0.02 * k + 0.01).all()


def test_resumed_run_appends_to_the_csv(tmp_path):
    probes = {"points": [{"name": "mid", "at": [0.5, 0.25]}], "every": 0.05}
    assert run(tmp_path, tank(probes), "--duration", 0.1, "--every", 0.05,
               "--checkpoint-every", 0.1) == 0
    csv = tmp_path / "out" / "probes.csv"
    with open(csv, "a") as f:  # a row the stopped run wrote after its checkpoint
        f.write("0.125,1,2,3,4\n")
    assert run(tmp_path, tank(probes), "--duration", 0.2, "--every", 0.05, "--resume",
               tmp_path / "out" / "checkpoint.npz") == 0
    text = csv.read_text()
    assert text.count("# sphfluid probes:") == 1 and text.count("time,") == 1
    _, _, rows = pr.read_csv(csv)
    np.testing.assert_allclose(rows[:, 0], [0, 0.05, 0.1, 0.15, 0.2], atol=1e-12)


def test_run_without_out_says_the_probes_need_it(tmp_path, capsys):
    path = tmp_path / "scene.json"
    path.write_text(json.dumps(tank()))
    assert main(["run", str(path), "--duration", "0.01", "--quiet"]) == 0
    assert "--out DIR only" in capsys.readouterr().err
