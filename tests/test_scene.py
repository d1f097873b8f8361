"""Scene validation: a table of broken scenes, each with its own message."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest
import sphfluid
from conftest import BASE_SCENE, SCENE_IDS, SCENES
from sphfluid.scene import SceneError


def broken(edit):
    d = copy.deepcopy(BASE_SCENE)
    edit(d)
    return d


def setp(path, value):
    def edit(d):
        *head, last = path
        for k in head:
            d = d[k]
        d[last] = value
    return edit


def delp(path):
    def edit(d):
        *head, last = path
        for k in head:
            d = d[k]
        del d[last]
    return edit


CASES = [
    (setp(["format"], "sphfluid-scene/2"), r'format: expected "sphfluid-scene/1", got "sphfluid-scene/2"'),
    (delp(["format"]), r"format: required key is missing"),
    (setp(["solvr"], {}), r'solvr: unknown key \(did you mean "solver"\?\)'),
    (setp(["fluid", "rest_density"], -1), r"fluid.rest_density: must be > 0, got -1"),
    (setp(["fluid", "rest_density"], "1000"), r"fluid.rest_density: expected a number, got the string \"1000\""),
    (setp(["fluid", "rest_density"], True), r"fluid.rest_density: expected a number, got a boolean"),
    (delp(["fluid", "gas_constant"]), r"fluid.gas_constant: required key is missing \(the seed method"),
    (setp(["fluid", "viscosity"], -0.1), r"fluid.viscosity: must be >= 0, got -0.1"),
    (setp(["fluid", "viscocity"], 1.0), r'fluid.viscocity: unknown key \(did you mean "viscosity"\?\)'),
    (setp(["gravity"], [0, -9.81, 0]), r"gravity: expected \[x, y\], got \[0, -9.81, 0\]"),
    (setp(["domain", "min"], [2.0, 0.0]), r"domain: min must be below max in x and y"),
    (delp(["domain"]), r"domain: required key is missing"),
    (setp(["resolution", "spacing"], 0), r"resolution.spacing: must be > 0, got 0"),
    (setp(["resolution", "smoothing_length"], 0.04), r"resolution.smoothing_length: must be > spacing"),
    (setp(["walls", 0], [[0.5, 0.5], [0.5, 0.5]]), r"walls\[0\]: segment has zero length"),
    (setp(["walls", 0], {"polyline": [[0, 0], [1, 0], [1, 0]]}), r"walls\[0\].polyline\[2\]: repeats the previous point"),
    (setp(["walls", 0], {"polyline": [[0, 0]]}), r"walls\[0\].polyline: expected a list of at least 2 points"),
    (setp(["walls", 0], {"polyline": [[0, 0], [1, 0]], "closd": True}), r'walls\[0\].closd: unknown key \(did you mean "closed"\?\)'),
    (setp(["walls", 0], [[0, 0], [1, "a"]]), r"walls\[0\]\[1\]\[1\]: expected a number, got the string \"a\""),
    (setp(["walls", 0], 5), r"walls\[0\]: expected a segment"),
    (setp(["fluid_regions", 0, "shape"], "rectangel"), r'fluid_regions\[0\].shape: expected one of "rectangle", "circle", "polygon", got "rectangel" \(did you mean "rectangle"\?\)'),
    (setp(["fluid_regions", 0, "max"], [0.0, 0.5]), r"fluid_regions\[0\]: min must be below max"),
    (setp(["fluid_regions", 0, "max"], [1.5, 0.5]), r"fluid_regions\[0\]: reaches outside the domain"),
    (setp(["fluid_regions", 0], {"shape": "circle", "center": [0.5, 0.5]}), r"fluid_regions\[0\].radius: required key is missing"),
    (setp(["fluid_regions", 0], {"shape": "circle", "center": [0.5, 0.5], "radius": 0.01}), r"fluid_regions\[0\]: holds no lattice point"),
    (setp(["fluid_regions", 0], {"shape": "polygon", "points": [[0, 0], [0.5, 0.5], [0.5, 0], [0, 0.5]]}), r"fluid_regions\[0\].points: polygon is not simple: edge 0 crosses edge 2"),
    (setp(["fluid_regions", 0], {"shape": "polygon", "points": [[0, 0], [0.5, 0.5]]}), r"fluid_regions\[0\].points: expected a list of at least 3 points"),
    (setp(["fluid_regions", 0, "velocity"], [1.0]), r"fluid_regions\[0\].velocity: expected \[x, y\]"),
    (setp(["fluid_regions", 0, "colour"], "blue"), r"fluid_regions\[0\].colour: unknown key"),
    (setp(["solver", "method"], "sead"), r'solver.method: expected one of "seed", "wcsph", "dfsph", got "sead" \(did you mean "seed"\?\)'),
    (delp(["solver", "time_step"]), r"solver.time_step: required key is missing"),
    (setp(["solver", "time_step"], -0.001), r"solver.time_step: must be > 0, got -0.001"),
    (setp(["solver", "wall_restitution"], 1.5), r"solver.wall_restitution: must be <= 1, got 1.5"),
    (setp(["duration"], float("inf")), r"duration: must be finite"),
    (setp(["resolution", "spacing"], 1e-6), r"domain: spans .* cells|fluid_regions: would create about"),
    (setp(["fluid_regions"], {}), r"fluid_regions: expected a list, got an object"),
    (setp(["walls", 0], [[0, 0], [1e9, 0]]), r"walls\[0\]: reaches \[1e\+09, 0\], farther from "
     r"the domain"),
    # null where a section is required: refused like any other wrong type
    (setp(["format"], None), r'format: expected "sphfluid-scene/1", got null'),
    (setp(["domain"], None), r"domain: expected an object, got null"),
    (setp(["fluid"], None), r"fluid: expected an object, got null"),
    (setp(["resolution"], None), r"resolution: expected an object, got null"),
    (setp(["fluid_regions"], None), r"fluid_regions: expected a list, got null"),
    (setp(["fluid_regions", 0, "shape"], ["circle"]), r'fluid_regions\[0\].shape: expected one of "rectangle", "circle", "polygon", got \["circle"\]'),
    (setp(["fluid_regions", 0, "shape"], {}), r'fluid_regions\[0\].shape: expected one of "rectangle", "circle", "polygon", got \{\}'),
]


@pytest.mark.parametrize("edit,message", CASES, ids=[c[1][:40] for c in CASES])
def test_broken_scene_gives_its_message(edit, message):
    with pytest.raises(SceneError, match=message):
        sphfluid.load_scene(broken(edit))


def test_every_problem_is_reported_at_once():
    def edit(d):
        d["fluid"]["rest_density"] = -1
        d["solvr"] = {}
        d["walls"][0] = [[0, 0], [0, 0]]

    with pytest.raises(SceneError) as info:
        sphfluid.load_scene(broken(edit))
    assert len(info.value.problems) == 3
    assert "3 problems" in str(info.value)


def test_memory_limit_names_the_particle_count():
    def edit(d):
        d["domain"] = {"min": [-1.0, -1.0], "max": [2000.0, 2000.0]}
        d["resolution"] = {"spacing": 0.05, "smoothing_length": 0.5}
        d["fluid_regions"][0]["max"] = [1990.0, 1990.0]
        d["walls"] = []

    with pytest.raises(SceneError, match=r"would create about 1,584,\d{3},\d{3} particles"):
        sphfluid.load_scene(broken(edit))


def test_invalid_json_names_line_and_column(tmp_path):
    f = tmp_path / "bad.json"
    f.write_text('{\n  "format": "sphfluid-scene/1",\n  "name": "x" "y"\n}')
    with pytest.raises(SceneError, match=r"bad.json: invalid JSON at line 3, column 15"):
        sphfluid.load_scene(f)


def test_duplicate_key_is_refused(tmp_path):
    f = tmp_path / "dup.json"
    f.write_text(json.dumps(BASE_SCENE)[:-1] + ', "duration": 3}')
    with pytest.raises(SceneError, match="duplicate key 'duration'"):
        sphfluid.load_scene(f)


def test_missing_file(tmp_path):
    with pytest.raises(SceneError, match="nope.json: file not found"):
        sphfluid.load_scene(tmp_path / "nope.json")


def test_top_level_must_be_an_object(tmp_path):
    f = tmp_path / "list.json"
    f.write_text("[1, 2]")
    with pytest.raises(SceneError, match="expected a JSON object at the top level"):
        sphfluid.load_scene(f)


def test_the_contract_example_loads():
    # The example scene of SCENE_FORMAT.md, verbatim.
    example = {
        "format": "sphfluid-scene/1",
        "name": "Dam break, 1 x 2 m column",
        "gravity": [0.0, -9.81],
        "domain": {"min": [-0.1, -0.1], "max": [4.1, 3.1]},
        "fluid": {"rest_density": 1000.0, "gas_constant": 250.0, "viscosity": 0.1,
                  "surface_tension": 0.0},
        "resolution": {"spacing": 0.02, "smoothing_length": 0.04},
        "fluid_regions": [
            {"shape": "rectangle", "min": [0.0, 0.0], "max": [1.0, 2.0]},
            {"shape": "circle", "center": [3.0, 2.5], "radius": 0.2, "velocity": [0.0, -1.0]},
            {"shape": "polygon", "points": [[2.0, 0.0], [2.5, 0.0], [2.25, 0.4]]},
        ],
        "walls": [[[0.0, 0.0], [4.0, 0.0]], [[4.0, 0.0], [4.0, 3.0]],
                  {"polyline": [[0.0, 3.0], [0.0, 0.0]]}],
        "solver": {"method": "seed", "time_step": 0.0002},
        "duration": 2.0,
    }
    scene = sphfluid.load_scene(example)
    pos, vel = scene.lattice_points()
    assert scene.name == "Dam break, 1 x 2 m column"  # once lost to a loop variable
    assert scene.to_dict()["name"] == example["name"]
    assert len(scene.walls) == 3
    # The rectangle alone is 50 x 100 lattice points; the circle moves down.
    assert ((pos[:, 0] < 1.0) & (pos[:, 1] < 2.0)).sum() == 5000
    assert np.all(vel[np.hypot(pos[:, 0] - 3.0, pos[:, 1] - 2.5) <= 0.2] == [0.0, -1.0])


def test_defaults_fill_optional_keys(scene_dict):
    for key in ("gravity", "name", "duration"):
        scene_dict.pop(key)
    scene_dict["fluid"] = {"rest_density": 1000.0, "gas_constant": 100.0}
    scene_dict["resolution"] = {"spacing": 0.05}
    scene = sphfluid.load_scene(scene_dict)
    assert scene.gravity == (0.0, -9.81)
    assert scene.viscosity == 0.0 and scene.surface_tension == 0.0
    assert scene.smoothing_length == pytest.approx(0.1)
    assert scene.duration is None


def test_overlapping_regions_make_each_lattice_point_once(scene_dict):
    scene_dict["fluid_regions"].append({"shape": "rectangle", "min": [0.25, 0.25],
                                        "max": [0.75, 0.75], "velocity": [1.0, 0.0]})
    pos, vel = sphfluid.load_scene(scene_dict).lattice_points()
    assert len(np.unique(pos, axis=0)) == len(pos) == 100 + 100 - 25
    # A point in both keeps the first region's velocity.
    both = np.all((pos > 0.25) & (pos < 0.5), axis=1)
    assert both.sum() == 25 and np.all(vel[both] == 0.0)


@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_bundled_scene_round_trips_through_to_dict(path):
    scene = sphfluid.load_scene(path)
    again = sphfluid.load_scene(json.loads(json.dumps(scene.to_dict())))
    assert again == scene


def _schema_validator():
    import jsonschema
    from sphfluid.schema import scene_schema

    return jsonschema.Draft202012Validator(scene_schema())


def test_the_schema_is_a_valid_json_schema():
    import jsonschema
    from sphfluid.schema import scene_schema

    jsonschema.Draft202012Validator.check_schema(scene_schema())


@pytest.mark.parametrize("edit,message", CASES, ids=[c[1][:40] for c in CASES])
def test_the_schema_alone_refuses_exactly_the_type_and_range_mistakes(edit, message):
    # The loader reports the schema's problems first, then its own (geometry,
    # comparisons between values, memory): a message comes from the schema
    # exactly when a plain JSON Schema validator refuses the scene (numbers
    # that are not finite aside: JSON has none, a schema cannot refuse them).
    from sphfluid.schema import problems

    data = broken(edit)
    plain = not _schema_validator().is_valid(data)
    finite = all(np.isfinite(v) for v in _numbers(data))
    assert bool(problems(data)) == (plain or not finite)
    with pytest.raises(SceneError) as info:
        sphfluid.load_scene(data)
    from_schema = {f"{path}: {msg}" for path, msg in problems(data)}
    assert from_schema <= set(info.value.problems)


def _numbers(value):
    if isinstance(value, dict):
        value = list(value.values())
    if isinstance(value, list):
        return [x for v in value for x in _numbers(v)]
    return [value] if isinstance(value, float) else []


@pytest.mark.parametrize("path", SCENES, ids=SCENE_IDS)
def test_bundled_scenes_and_their_round_trips_meet_the_schema(path):
    validator = _schema_validator()
    assert validator.is_valid(json.loads(path.read_text()))
    assert validator.is_valid(sphfluid.load_scene(path).to_dict())


def test_scene_defaults_are_the_schemas():
    import dataclasses

    from sphfluid.schema import default

    fields = {f.name: f.default for f in dataclasses.fields(sphfluid.Scene)}
    assert fields["gravity"] == tuple(default("gravity"))
    assert fields["periodic"] == tuple(default("domain", "periodic"))
    for key in ("viscosity", "surface_tension", "artificial_viscosity", "background_pressure"):
        assert fields[key] == default("fluid", key), key
    for key in ("cfl", "on_instability", "pair_precision", "density_diffusion", "shifting",
                "free_surface", "viscosity_reconstruction"):
        assert fields[key] == default("solver", key), key
    assert fields["wall_restitution"] == default("solver", "wall_restitution")
    assert fields["method"] == default("solver", "method")


def test_a_rule_between_keys_comes_from_the_schema():
    def edit(d):
        d["solver"]["cfl"] = 0.3  # with a fixed time step

    data = broken(edit)
    assert not _schema_validator().is_valid(data)
    with pytest.raises(SceneError, match=r'solver.cfl: only applies with "time_step": "auto"'):
        sphfluid.load_scene(data)


def test_malformed_values_give_messages_not_tracebacks():
    cases = [
        (setp(["fluid", "rest_density"], 10**400), r"fluid.rest_density: must be finite"),
        (setp(["resolution"], {"spacing": 0.9e308}), r"resolution.spacing: must be smaller than the domain"),
        (setp(["name"], [[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]]),
         r"nested more than 64 levels deep"),
        (setp(["solver"], None), r"solver: expected an object, got null"),
        (lambda d: d.update(name=json.loads("[" * 100 + "]" * 100), gravity={}),
         r"^name(\[0\])+: nested more than 64 levels deep$"),
        (setp(["walls", 0], [[0, 0], [1e-320, 0]]), r"walls\[0\]: segment has zero length"),
        (setp(["fluid_regions", 0], {}), r'fluid_regions\[0\].shape: required key is missing'),
    ]
    for edit, message in cases:
        with pytest.raises(SceneError, match=message):
            sphfluid.load_scene(broken(edit))


def _first_crossing_by_brute_force(pts):
    """Every pair of non-neighbouring edges, in order: the first that touch."""
    def orient(a, b, c):
        v = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
        return (v > 0) - (v < 0)

    def on(a, b, c):
        return (min(a[0], b[0]) <= c[0] <= max(a[0], b[0])
                and min(a[1], b[1]) <= c[1] <= max(a[1], b[1]))

    n = len(pts)
    edges = [(pts[i], pts[(i + 1) % n]) for i in range(n)]
    for i in range(n):
        for j in range(i + 2, n):
            if i == 0 and j == n - 1:
                continue
            (p1, p2), (q1, q2) = edges[i], edges[j]
            o = orient(p1, p2, q1), orient(p1, p2, q2), orient(q1, q2, p1), orient(q1, q2, p2)
            if ((o[0] != o[1] and o[2] != o[3]) or (o[0] == 0 and on(p1, p2, q1))
                    or (o[1] == 0 and on(p1, p2, q2)) or (o[2] == 0 and on(q1, q2, p1))
                    or (o[3] == 0 and on(q1, q2, p2))):
                return (i, j)
    return None


def test_the_polygon_check_finds_the_first_crossing_a_brute_force_finds():
    # Vertices on a small integer grid: collinear edges, touching vertices and
    # repeated points are common, the cases a sweep gets wrong.
    from sphfluid.scene import _self_intersection

    rng = np.random.default_rng(7)
    for _ in range(2000):
        pts = [tuple(map(float, p)) for p in rng.integers(0, 5, size=(rng.integers(3, 12), 2))]
        assert _self_intersection(pts) == _first_crossing_by_brute_force(pts), pts


def test_a_polygon_of_many_vertices_loads(scene_dict):
    # 20,000 vertices on a wavy closed curve, and the same with one edge crossing.
    t = np.linspace(0, 2 * np.pi, 20_000, endpoint=False)
    r = 0.3 * (1 + 0.1 * np.sin(40 * t))
    pts = np.stack([0.5 + r * np.cos(t), 0.5 + r * np.sin(t)], axis=1).tolist()
    scene_dict["fluid_regions"] = [{"shape": "polygon", "points": pts}]
    assert len(sphfluid.load_scene(scene_dict).lattice_points()[0]) > 0
    pts[100], pts[101] = pts[101], pts[100]
    with pytest.raises(SceneError, match=r"fluid_regions\[0\].points: polygon is not simple: "
                                         r"edge 99 crosses edge 101"):
        sphfluid.load_scene(scene_dict)
