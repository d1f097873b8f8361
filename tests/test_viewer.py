"""Viewer and recorder, headless (SDL dummy driver)."""
from __future__ import annotations

import gc
import json
import os
import warnings

import numpy as np
import pytest
from conftest import BASE_SCENE, ROOT

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
pygame = pytest.importorskip("pygame")

import sphfluid
from sphfluid.cli import main
from sphfluid.metadata import scene_hash
from sphfluid.viewer import BACKGROUND, MODES, SINK, Renderer, save_scene


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
    cx, cy = (round(float(v)) for v in cam.to_screen(np.array([0.5, 1.0])))
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
    top = img[tuple(round(float(v)) for v in cam.to_screen(np.array([0.5, 0.9])))]
    bottom = img[tuple(round(float(v)) for v in cam.to_screen(np.array([0.5, 0.05])))]
    # High pressure at the bottom is drawn redder than the low pressure near the top.
    assert int(bottom[0]) - int(bottom[2]) > int(top[0]) - int(top[2])


def test_pressure_scale_of_a_drop_in_zero_gravity_is_its_laplace_pressure(display):
    # The bundled droplet: no gravity, so the hydrostatic head is 0; the colour
    # scale follows sigma/R (a 0.4 m square: R = 0.2 m, 50 Pa) instead of 1 Pa.
    d = json.loads((ROOT / "scenes" / "droplet.json").read_text())
    d["solver"].update(method="wcsph", time_step="auto")
    sim = sphfluid.Simulation(d)
    sim.run(0.5)
    _, r = render(sim, "pressure")
    values, _, low, high = r.field()
    assert high == pytest.approx(2 * 10.0 / 0.2 / 1000) and low == -high  # kPa
    inside = np.median(values[values > 0])
    assert 0.1 * high < inside < high  # the inside is coloured, not saturated


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
    from PIL import Image

    with Image.open(frames[0]) as png:  # the run metadata, in a text chunk
        meta = json.loads(png.text["sphfluid_metadata"])
    assert meta["scene_hash"] == scene_hash(sphfluid.load_scene(BASE_SCENE))


def test_record_refuses_an_unknown_file_type(tmp_path, capsys):
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["record", str(scene), "--out", str(tmp_path / "movie.avi")]) == 2
    assert "expected a folder for PNG frames, a .gif or an .mp4 file" in capsys.readouterr().err


def scripted_view(scene, events, frames, size=(500, 400)):
    """Run the viewer headless, posting events[frame] at each frame; returns the sim."""
    from sphfluid.viewer import view

    box = {}

    def script(frame, pg, sim):
        box["sim"] = sim
        for make in events.get(frame, []):
            pg.event.post(make(pg))

    assert view(scene, frames=frames, size=size, steps_per_frame=20, script=script) == 0
    return box["sim"]


def screen_of(scene, size, point):
    from sphfluid.viewer import Camera

    x, y = Camera(scene, size).to_screen(np.asarray(point, float))
    return round(float(x)), round(float(y))


def falling_block(tmp_path):
    d = copy_scene()
    d["fluid"].update(gas_constant=20.0, viscosity=5.0)
    d["fluid_regions"] = [{"shape": "rectangle", "min": [0.3, 0.6], "max": [0.7, 0.9]}]
    return sphfluid.load_scene(d)


def copy_scene():
    return json.loads(json.dumps(BASE_SCENE))


def test_a_wall_drawn_with_the_mouse_is_respected(tmp_path):
    scene = falling_block(tmp_path)
    size = (500, 400)
    a, b = screen_of(scene, size, (0.0, 0.3)), screen_of(scene, size, (1.0, 0.3))
    events = {1: [lambda pg: pg.event.Event(pg.MOUSEBUTTONDOWN, button=1, pos=a)],
              2: [lambda pg: pg.event.Event(pg.MOUSEMOTION, pos=b, rel=(0, 0), buttons=(1, 0, 0)),
                  lambda pg: pg.event.Event(pg.MOUSEBUTTONUP, button=1, pos=b)]}
    sim = scripted_view(scene, events, frames=4, size=size)
    assert len(sim.scene.walls) == len(scene.walls) + 1
    (_, y1), (_, y2) = sim.scene.walls[-1]
    # Both ends snapped onto the box's side walls (x = 0 and x = 1 are wall lines;
    # the nearest end points are the box corners only if within the snap radius).
    assert y1 == pytest.approx(0.3, abs=0.02) and y2 == pytest.approx(0.3, abs=0.02)
    sim.run(0.6)
    assert sim.positions[:, 1].min() > min(y1, y2)  # the block landed on the new wall


def hover_and_press(pos, key: str) -> list:
    """Events of one frame: the mouse moves to pos, then the key is pressed."""
    return [lambda pg: pg.event.Event(pg.MOUSEMOTION, pos=pos, rel=(0, 0), buttons=(0, 0, 0)),
            lambda pg: pg.event.Event(pg.KEYDOWN, key=getattr(pg, key), mod=0)]


def test_deleting_the_wall_under_the_cursor(tmp_path):
    scene = falling_block(tmp_path)
    size = (500, 400)
    events = {1: hover_and_press(screen_of(scene, size, (0.5, 0.0)), "K_x")}
    sim = scripted_view(scene, events, frames=3, size=size)
    assert len(sim.scene.walls) == len(scene.walls) - 1
    assert ((0.0, 0.0), (1.0, 0.0)) not in sim.scene.walls


def test_pouring_is_an_emitter_that_ctrl_s_saves(tmp_path, monkeypatch):
    """E starts an emitter at the cursor, E again stops it; Ctrl+S saves it with the
    scene, and the saved scene pours the same again."""
    monkeypatch.chdir(tmp_path)
    scene = falling_block(tmp_path)
    size = (500, 400)
    at = screen_of(scene, size, (0.5, 0.95))
    ctrl_s = [lambda pg: pg.event.Event(pg.KEYDOWN, key=pg.K_s, mod=pg.KMOD_CTRL)]
    events = {1: hover_and_press(at, "K_e"), 20: hover_and_press(at, "K_e"), 22: ctrl_s}
    n0 = sphfluid.Simulation(scene).n_particles
    sim = scripted_view(scene, events, frames=24, size=size)
    (e,) = sim.scene.emitters
    assert e.at == pytest.approx((0.5, 0.95), abs=0.01) and e.stop > e.start
    assert sim.balance["in"] >= 6 and sim.n_particles == n0 + sim.balance["in"] - \
        sim.balance["lost"] - sim.balance["sunk"]
    assert np.all(np.isfinite(sim.positions))
    (saved,) = tmp_path.glob("*_saved.json")
    again = sphfluid.load_scene(saved)
    assert again.emitters == sim.scene.emitters
    replay = sphfluid.Simulation(again)
    replay.advance_to(e.stop + 0.01)
    assert replay.balance["in"] == sim.balance["in"]


def test_pouring_started_and_stopped_while_paused_leaves_no_emitter(tmp_path):
    scene = falling_block(tmp_path)
    size = (500, 400)
    at = screen_of(scene, size, (0.5, 0.95))
    space = [lambda pg: pg.event.Event(pg.KEYDOWN, key=pg.K_SPACE, mod=0)]
    events = {1: space, 2: hover_and_press(at, "K_e"), 3: hover_and_press(at, "K_e")}
    sim = scripted_view(scene, events, frames=5, size=size)
    assert sim.scene.emitters == () and sim.balance["in"] == 0


def test_right_drag_pushes_the_fluid(tmp_path):
    scene = falling_block(tmp_path)
    size = (500, 400)
    centre = screen_of(scene, size, (0.5, 0.75))
    events = {1: [lambda pg: pg.event.Event(pg.MOUSEMOTION, pos=centre, rel=(20, 0),
                                            buttons=(0, 0, 1))]}
    sim = scripted_view(scene, events, frames=2, size=size)
    assert sim.velocities[:, 0].max() > 1.0  # dragged to the right


def test_zoom_keeps_the_point_under_the_cursor():
    from sphfluid.viewer import Camera

    scene = sphfluid.load_scene(BASE_SCENE)
    cam = Camera(scene, (500, 400))
    before = cam.to_world(123, 77)
    cam.zoom(1.25**3, 123, 77)
    assert cam.to_world(123, 77) == pytest.approx(before)
    cam.pan(10, -5)
    assert cam.to_world(133, 72) == pytest.approx(before)


def test_record_writes_a_gif(tmp_path, capsys):
    from PIL import Image as image  # a dependency of the plain install

    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    out = tmp_path / "movie.gif"
    assert main(["record", str(scene), "--out", str(out), "--duration", "0.1", "--fps", "20",
                 "--size", "200x150", "--mode", "surface"]) == 0
    with image.open(out) as gif:
        assert gif.size == (200, 150) and gif.n_frames == 3
        meta = json.loads(gif.info["comment"])
    assert meta["method"] == "seed" and meta["sphfluid_version"] == sphfluid.__version__


def test_liquid_mode_draws_a_smooth_anti_aliased_surface(display):
    """The tank at rest in liquid mode: the water's top edge is one straight row
    of pixels at the fill height (no cell steps), edged with blended colours."""
    from sphfluid.viewer import LIQUID

    sim = sphfluid.Simulation(json.loads((ROOT / "scenes" / "water" /
                                          "hydrostatic.json").read_text()))
    img, r = render(sim, "surface", size=(600, 500))
    (x0, _), (x1, y1) = sim.scene.regions[0].bounds()
    left, _ = r.camera.to_screen(np.array([x0 + 0.1, y1]))
    right, top = r.camera.to_screen(np.array([x1 - 0.1, y1]))
    liquid = np.all(img == LIQUID, axis=2)
    tops = [int(np.flatnonzero(liquid[x])[0]) for x in range(int(left), int(right))]
    assert max(tops) - min(tops) <= 1 and abs(np.median(tops) - float(top)) <= 2
    # between the body and the background above it, the rim's blended pixels
    column = img[int(left) + 5, :, :].astype(int)
    above = column[int(top) - 6:int(top) + 3]
    plain = {tuple(c) for c in (LIQUID, BACKGROUND)}
    assert any(tuple(c) not in plain for c in above)


def test_record_writes_an_mp4_at_the_frame_rate(tmp_path):
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    out = tmp_path / "movie.mp4"
    assert main(["record", str(scene), "--out", str(out), "--duration", "0.15", "--fps", "20",
                 "--size", "201x150", "--quiet"]) == 0
    with warnings.catch_warnings():  # the reader leaves ffmpeg's pipes to the collector
        warnings.simplefilter("ignore", ResourceWarning)
        reader = imageio_ffmpeg.read_frames(str(out))
        meta = next(reader)
        frames = [np.frombuffer(f, np.uint8).reshape(150, 202, 3) for f in reader]
        del reader
        gc.collect()
    assert meta["codec"] == "h264" and meta["fps"] == 20 and meta["size"] == (202, 150)
    assert len(frames) == 4  # t = 0 .. 0.15
    assert not np.array_equal(frames[0], frames[-1])  # the fluid moved
    assert not list(tmp_path.glob(".*tmp*"))
    import subprocess

    import re

    probe = subprocess.run([imageio_ffmpeg.get_ffmpeg_exe(), "-loglevel", "error", "-i",
                            str(out), "-f", "ffmetadata", "-"],
                           capture_output=True, text=True, timeout=60)
    comment = next(line for line in probe.stdout.splitlines() if line.startswith("comment="))
    meta = json.loads(re.sub(r"\\(.)", r"\1", comment[len("comment="):]))  # unescaped
    assert meta["scene_hash"] == scene_hash(sphfluid.load_scene(BASE_SCENE))


def test_an_mp4_without_imageio_ffmpeg_names_the_extra(tmp_path, monkeypatch, capsys):
    import sys

    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)
    scene = tmp_path / "s.json"
    scene.write_text(json.dumps(BASE_SCENE))
    assert main(["record", str(scene), "--out", str(tmp_path / "m.mp4"), "--duration", "0.1",
                 "--quiet"]) == 2
    assert 'pip install "sphfluid[video]"' in capsys.readouterr().err
    assert not list(tmp_path.glob("*.mp4")) and not list(tmp_path.glob(".*"))


@pytest.mark.parametrize("name", ["m.gif", "m.mp4"])
def test_a_recording_that_fails_leaves_no_file(tmp_path, monkeypatch, name):
    """A run that stops part way (here a blow-up at the third frame) leaves
    neither the movie nor its temporary file."""
    if name.endswith("mp4"):
        pytest.importorskip("imageio_ffmpeg")
    from sphfluid.viewer import record

    calls = []

    def advance(self, t, max_steps=None):
        calls.append(t)
        if len(calls) == 3:
            raise sphfluid.InstabilityError("blew up")
        return 0

    monkeypatch.setattr(sphfluid.Simulation, "advance_to", advance)
    with pytest.raises(sphfluid.InstabilityError):
        record(BASE_SCENE, tmp_path / name, duration=0.2, fps=20, size=(120, 90))
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("mode", ["pressure", "surface"])
def test_the_scenes_probes_are_marked(display, mode):
    """A ring at a point probe, the dashed line of a surface probe and a wall
    group drawn over its wall, in the probe colour; none without probes."""
    from sphfluid.viewer import PROBE

    d = json.loads((ROOT / "scenes" / "water" / "hydrostatic.json").read_text())
    d["probes"] = {"points": [{"name": "p", "at": [0.5, 1.3]}], "surface": [{"name": "s",
                   "x": 0.25}], "walls": [{"name": "w", "segments": [1]}]}
    img, r = render(sphfluid.Simulation(d), mode, size=(500, 400))
    probe = np.all(img == PROBE, axis=2)
    cx, cy = (round(float(v)) for v in r.camera.to_screen(np.array([0.5, 1.3])))
    assert probe[cx - 6:cx + 7, cy - 6:cy + 7].sum() > 10  # the ring
    sx, _ = r.camera.to_screen(np.array([0.25, 0.0]))
    assert probe[round(float(sx))].sum() > 50  # the dashed line, top to bottom
    fx, fy = (round(float(v)) for v in r.camera.to_screen(np.array([0.7, 0.0])))
    assert probe[fx, fy - 2:fy + 3].any()  # the floor, drawn over
    del d["probes"]
    img, _ = render(sphfluid.Simulation(d), mode, size=(500, 400))
    assert not np.all(img == PROBE, axis=2).any()


def editor_for(scene, size=(500, 400)):
    from sphfluid.viewer import Editor

    sim = sphfluid.Simulation(scene)
    renderer = Renderer(sim, size, "speed")
    return sim, Editor(sim, renderer), lambda p: screen_of(scene, size, p)


def drag(editor, a, b) -> str:
    editor.begin_drag(*a)
    return editor.end_drag(*b)


def test_the_editor_places_flows_on_the_drag_and_ctrl_s_keeps_them(display, tmp_path):
    """K, I, O and B arm the next left-drag (then walls again): a sink's rectangle
    corner to corner, an inlet's and an outlet's line with the flow to the drag's
    right, a damping zone from where it begins to full strength; each acts in the
    run, and the saved scene loads with them."""
    scene = falling_block(tmp_path)
    sim, editor, px = editor_for(scene)
    assert editor.arm("sink") and editor.tool == "sink"
    assert drag(editor, px((0.02, 0.02)), px((0.98, 0.15))) == "sink added (Ctrl+S saves it)"
    assert editor.tool == "wall"
    (sink,) = sim.scene.sinks
    assert np.allclose(sink.bounds(), ((0.02, 0.02), (0.98, 0.15)), atol=0.01)
    editor.arm("inlet")
    assert drag(editor, px((0.3, 0.2)), px((0.3, 0.45))) == "inlet added (Ctrl+S saves it)"
    (inlet,) = sim.scene.inlets
    assert np.allclose(inlet.unit(), (1.0, 0.0), atol=0.02)  # upwards: to the right
    assert inlet.width == pytest.approx(0.25, abs=0.01)
    editor.arm("outlet")
    drag(editor, px((0.75, 0.45)), px((0.75, 0.2)))  # downwards: to the left
    (outlet,) = sim.scene.outlets
    assert np.allclose(outlet.unit(), (-1.0, 0.0), atol=0.02)
    editor.arm("damping zone")
    drag(editor, px((0.6, 0.5)), px((0.9, 0.5)))
    (zone,) = sim.scene.damping_zones
    assert np.allclose([zone.start, zone.end], [(0.6, 0.5), (0.9, 0.5)], atol=0.01)
    sim.run(0.8)
    b = sim.balance
    assert b["in"] > 0 and b["sunk"] > 0  # the inlet fed, the block fell into the sink
    path = save_scene(sim, tmp_path / "edited.json")
    again = sphfluid.load_scene(path)
    assert (again.sinks, again.inlets, again.outlets, again.damping_zones) == (
        sim.scene.sinks, sim.scene.inlets, sim.scene.outlets, sim.scene.damping_zones)


def test_the_editor_refuses_what_the_scene_format_refuses_and_deletes(display, tmp_path):
    """A sink over the initial fluid, an inlet whose buffer holds initial fluid or
    fluid now are refused with the reason, nothing changed; X deletes the sink the
    cursor is in, the inlet line and the damping zone's first line under it."""
    scene = falling_block(tmp_path)
    sim, editor, px = editor_for(scene)
    editor.arm("sink")
    msg = drag(editor, px((0.4, 0.7)), px((0.6, 0.8)))
    assert msg.startswith("sink not added: ") and "initial fluid" in msg
    assert sim.scene.sinks == () and editor.tool == "sink"  # still armed: try again
    editor.arm("inlet")
    msg = drag(editor, px((0.5, 0.95)), px((0.5, 0.55)))  # its buffer over the block
    assert msg.startswith("inlet not added: ") and sim.scene.inlets == ()
    sim.run(0.6)  # the block lies on the floor: a buffer there would overlap it
    msg = drag(editor, px((0.5, 0.02)), px((0.5, 0.25)))
    assert msg.startswith("inlet not added: ") and "the fluid now" in msg, msg
    sim.reset()
    n = sim.n_particles
    editor.arm("sink")
    drag(editor, px((0.02, 0.02)), px((0.98, 0.15)))
    editor.arm("inlet")
    drag(editor, px((0.3, 0.2)), px((0.3, 0.45)))
    editor.arm("damping zone")
    drag(editor, px((0.6, 0.5)), px((0.9, 0.5)))
    assert sim.n_particles > n  # the inlet's buffer
    assert editor.delete_at(*px((0.3, 0.3))) == "inlet deleted" and sim.scene.inlets == ()
    assert editor.delete_at(*px((0.6, 0.3))) == "damping zone deleted"
    assert sim.scene.damping_zones == ()
    assert editor.delete_at(*px((0.5, 0.1))) == "sink deleted" and sim.scene.sinks == ()
    assert editor.delete_at(*px((0.5, 0.7))) == ""  # nothing there


def test_the_tool_keys_arm_the_next_drag(tmp_path):
    scene = falling_block(tmp_path)
    size = (500, 400)
    a, b = screen_of(scene, size, (0.02, 0.02)), screen_of(scene, size, (0.98, 0.15))
    c, d = screen_of(scene, size, (0.2, 0.5)), screen_of(scene, size, (0.6, 0.5))
    down = lambda p: [lambda pg: pg.event.Event(pg.MOUSEBUTTONDOWN, button=1, pos=p)]  # noqa: E731
    up = lambda p: [lambda pg: pg.event.Event(pg.MOUSEBUTTONUP, button=1, pos=p)]  # noqa: E731
    events = {1: hover_and_press(a, "K_k"), 2: down(a), 3: up(b),  # a sink
              4: hover_and_press(a, "K_b"), 5: down(c), 6: up(d),  # a damping zone
              7: hover_and_press(a, "K_b"), 8: hover_and_press(a, "K_b"),  # B twice: walls
              9: down(c), 10: up(d)}
    sim = scripted_view(scene, events, frames=12, size=size)
    assert len(sim.scene.sinks) == 1 and len(sim.scene.damping_zones) == 1
    assert len(sim.scene.walls) == len(scene.walls) + 1


def test_m_makes_the_wall_under_the_cursor_a_paddle_and_again_stops_it(display, tmp_path):
    """M over the box's right wall: it oscillates along its normal a spacing
    either way from now on (the saved scene carries the motion); M again (over
    where it is then): it stops there, fixed."""
    scene = falling_block(tmp_path)
    sim, editor, px = editor_for(scene)
    right = [k for k, (a, b) in enumerate(sim.scene.walls) if a[0] == b[0] == 1.0][0]
    sim.step(10)
    t0 = sim.time
    msg = editor.toggle_motion(*px((1.0, 0.5)))
    assert msg.startswith("the wall moves 0.05 m either way"), msg
    motion = sim.scene.wall_motions[right]
    assert motion.translation[0] == (pytest.approx(t0), 0.0, 0.0)
    sim.advance_to(t0 + 1.25)  # a quarter period after the ramp: at its full stroke
    (a, b) = sim.walls[right]
    assert abs(a[0] - 1.0) == pytest.approx(0.05, rel=0.02) and a[0] == b[0]
    again = sphfluid.load_scene(save_scene(sim, tmp_path / "paddle.json"))
    assert again.wall_motions[right] == motion
    x_now = float(a[0])
    assert editor.toggle_motion(*px((x_now, 0.5))) == "the wall stopped where it is"
    assert not sim.scene.wall_motions or sim.scene.wall_motions[right] is None
    sim.advance_to(t0 + 1.5)
    assert sim.walls[right][0][0] == pytest.approx(x_now) and sim.scene.walls[right][0][0] == \
        pytest.approx(x_now)
    assert editor.toggle_motion(*px((0.5, 0.7))) == ""  # no wall there


@pytest.mark.parametrize("level", [None, 0.3])
def test_an_outlets_held_level_is_drawn_across_its_buffer(display, level):
    d = json.loads(json.dumps(BASE_SCENE))
    d["domain"]["max"] = [1.3, 1.1]
    d["walls"] = [{"polyline": [[0.0, 1.0], [0.0, 0.0], [1.3, 0.0]]}]
    d["outlets"] = [{"at": [0.5, 0.4], "direction": [1, 0], "width": 0.8}]
    if level is not None:
        d["outlets"][0]["level"] = level
    sim = sphfluid.Simulation(d)
    depth = sim.scene.buffer_depth()
    img, r = render(sim, "speed")
    (x,), (y,) = r.camera.to_screen(np.array([[0.5 + depth / 2, 0.3]]))
    drawn = [tuple(img[int(round(x)), int(round(y)) + k]) == SINK for k in (-1, 0, 1)]
    assert any(drawn) == (level is not None)
