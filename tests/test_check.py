"""The scene check before a run: `sphfluid check`, `sphfluid schema`, "$schema"."""
from __future__ import annotations

import json
from importlib import resources

import pytest
import sphfluid
from sphfluid.cli import main


def write(tmp_path, scene: dict, name: str = "scene.json"):
    path = tmp_path / name
    path.write_text(json.dumps(scene))
    return path


def test_schema_prints_the_shipped_schema(capsys):
    assert main(["schema"]) == 0
    printed = json.loads(capsys.readouterr().out)
    shipped = json.loads(resources.files("sphfluid").joinpath("scene.schema.json").read_text())
    assert printed == shipped
    assert printed["$schema"].startswith("https://json-schema.org/")


def test_a_scene_with_schema_key_loads(tmp_path, scene_dict):
    scene_dict = {"$schema": "./scene.schema.json", **scene_dict}
    scene = sphfluid.load_scene(write(tmp_path, scene_dict))
    assert scene.regions  # loaded as without the key
    bad = {**scene_dict, "$schema": 3}
    with pytest.raises(sphfluid.SceneError, match=r"\$schema: expected a string"):
        sphfluid.load_scene(bad)
    typo = {**scene_dict, "schema": "x"}
    with pytest.raises(sphfluid.SceneError, match=r'schema: unknown key \(did you mean "\$schema"'):
        sphfluid.load_scene(typo)
