"""Viewer and recorder, headless (SDL dummy driver)."""
from __future__ import annotations

import json
import os

import numpy as np
import pytest
from conftest import BASE_SCENE, ROOT

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
pygame = pytest.importorskip("pygame")

import sphfluid
from sphfluid.cli import main
from sphfluid.viewer import BACKGROUND, MODES, Renderer, save_scene


@pytest.fixture
def display():
    pygame.display.init()
    pygame.font.init()
    yield
    pygame.quit()


def render(sim, mode, size=(400, 300)):
    surface = pygame.Surface(size)
    r = Renderer(sim, size, mode)
    r.draw(surface)
    return pygame.surfarray.array3d(surface), r


@pytest.mark.parametrize("mode", MODES)
def test_fluid_pixels_where_the_fluid_is_and_none_elsewhere(display, mode):
    sim = sphfluid.Simulation(json.loads((ROOT / "scenes" / "dam_break.json").read_text()))
    img, r = render(sim, mode)
    bg = np.all(img == BACKGROUND, axis=2)
    cam = r.camera
    # The column (0..1 m x 0..2 m) shows fluid colours at its centre...
    cx, cy = (int(round(v)) for v in cam.to_screen(np.array([0.5, 1.0])))
    assert not bg[cx - 3:cx + 4, cy - 3:cy + 4].any()
    # ...and the empty half of the tank (2.5..3.5 m x 0.5..2 m) is background.
    x0, y1 = (int(v) for v in cam.to_screen(np.array([2.5, 0.5])))
    x1, y0 = (int(v) for v in cam.to_screen(np.array([3.5, 2.0])))
    assert bg[x0:x1, y0:y1].all()


def test_scalar_modes_colour_by_their_field(display):
    sim = sphfluid.Simulation(json.loads((ROOT / "scenes" / "hydrostatic.json").read_text()))
    sim.run(0.5)
    img, r = render(sim, "pressure")
    cam = r.camera
    top = img[tuple(int(round(v)) for v in cam.to_screen(np.array([0.5, 0.9])))]
    bottom = img[tuple(int(round(v)) for v in cam.to_screen(np.array([0.5, 0.05])))]
    # High pressure at the bottom is drawn redder than the low pressure near the top.
    assert int(bottom[0]) - int(bottom[2]) > int(top[0]) - int(top[2])


def test_saved_scene_loads_again_with_the_same_walls(display, tmp_path):
    scene = sphfluid.load_scene(ROOT / "scenes" / "terrain.json")
    sim = sphfluid.Simulation(scene)
    out = save_scene(sim, tmp_path / "saved.json")
    again = sphfluid.load_scene(out)
    assert again.walls == scene.walls and again == scene


def test_view_runs_every_mode_headless(tmp_path):
    for mode in MODES:
        shot = tmp_path / f"{mode}.png"
        assert main(["view", str(ROOT / "scenes" / "droplet.json"), "--frames", "3",
                     "--mode", mode, "--screenshot", str(shot), "--size", "300x200"]) == 0
        assert shot.exists()


def test_record_writes_png_frames(tmp_path, capsys):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["record", str(scene), "--out", str(tmp_path / "frames"), "--duration", "0.1",
                 "--fps", "20", "--size", "200x150"]) == 0
    frames = sorted((tmp_path / "frames").glob("frame_*.png"))
    assert len(frames) == 3  # t = 0, 0.05, 0.1
    assert pygame.image.load(str(frames[-1])).get_size() == (200, 150)
    assert "wrote 3 frames" in capsys.readouterr().out


def test_record_refuses_an_unknown_file_type(tmp_path, capsys):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["record", str(scene), "--out", str(tmp_path / "movie.avi")]) == 2
    assert "expected a folder for PNG frames or a .gif file" in capsys.readouterr().err
