"""A pygame window that runs a scene live, and headless frame recording.

pygame is imported inside the functions so that ``import sphfluid`` and headless
runs never need it or a display. Everything per particle is drawn in bulk from
numpy arrays into a pixel buffer, never one Python call per particle.
"""
from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np

from .scene import Scene, load_scene
from .simulation import InstabilityError, Simulation

BACKGROUND = (18, 20, 28)
WALL = (225, 225, 225)
TEXT = (235, 235, 235)
DIM = (150, 150, 160)
TARGET_FPS = 60
STEP_BUDGET = 0.030  # seconds of stepping per frame before slowing below real time

MODES = ("speed", "pressure", "density", "surface")  # keys 1-4
MODE_LABELS = {
    "speed": "speed (m/s)",
    "pressure": "pressure (kPa)",
    "density": "density error rho/rho0 - 1 (%)",
    "surface": "liquid surface",
}
HELP = [
    "left-drag  draw a wall (ends snap to wall ends)",
    "X or Delete  delete the wall under the cursor",
    "E  start / stop pouring fluid at the cursor",
    "right-drag  push the fluid",
    "wheel  zoom at the cursor   middle-drag  pan   0  fit the domain",
    "space  pause / run",
    "S or right arrow  one step",
    "R  reset to the scene",
    "+ / -  more / fewer steps per frame",
    "1 speed  2 pressure  3 density error  4 liquid surface",
    "P  screenshot (PNG)",
    "Ctrl+S  save the scene as JSON",
    "H  this help      Q or Esc  quit",
]


def ramp(stops, n: int = 256) -> np.ndarray:
    """A (n, 3) uint8 colour ramp through the given RGB stops."""
    stops = np.asarray(stops, float)
    t = np.linspace(0, len(stops) - 1, n)
    i = np.minimum(t.astype(int), len(stops) - 2)
    f = (t - i)[:, None]
    return (stops[i] * (1 - f) + stops[i + 1] * f).astype(np.uint8)


SEQUENTIAL = ramp([[20, 60, 160], [30, 130, 220], [60, 200, 230], [180, 240, 250],
                   [255, 255, 255]])
# Liquid surface: 256 depth shades, then the rim colour, then the background.
SURFACE_LUT = np.vstack([ramp([[120, 200, 255], [15, 60, 150]]),
                         [[220, 245, 255], list(BACKGROUND)]]).astype(np.uint8)
DIVERGING = ramp([[40, 80, 200], [120, 170, 230], [235, 235, 235], [240, 150, 100],
                  [200, 40, 40]])


def speed_colours(n: int = 256) -> np.ndarray:
    """The speed ramp, slow (deep blue) to fast (white)."""
    return ramp([[20, 60, 160], [30, 130, 220], [60, 200, 230], [180, 240, 250],
                 [255, 255, 255]], n)


class Camera:
    """Maps world coordinates (m, y up) to pixels (y down), fitting the domain."""

    def __init__(self, scene: Scene, size: tuple[int, int], margin: int = 10, top: int = 24,
                 bottom: int = 20, right: int = 70):
        (x0, y0), (x1, y1) = scene.domain_min, scene.domain_max
        w, h = size
        free_w = w - 2 * margin - right
        free_h = h - 2 * margin - top - bottom
        self.scale = max(1e-9, min(free_w / (x1 - x0), free_h / (y1 - y0)))
        self.ox = margin + 0.5 * (free_w - self.scale * (x1 - x0)) - self.scale * x0
        self.oy = top + margin + 0.5 * (free_h - self.scale * (y1 - y0)) + self.scale * y1

    def to_screen(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (self.ox + self.scale * xy[..., 0], self.oy - self.scale * xy[..., 1])

    def zoom(self, factor: float, px: float, py: float) -> None:
        """Zoom by factor, keeping the world point under pixel (px, py) in place."""
        wx, wy = self.to_world(px, py)
        self.scale *= factor
        self.ox, self.oy = px - self.scale * wx, py + self.scale * wy

    def pan(self, dpx: float, dpy: float) -> None:
        self.ox += dpx
        self.oy += dpy

    def to_world(self, px: float, py: float) -> tuple[float, float]:
        return ((px - self.ox) / self.scale, (self.oy - py) / self.scale)


class Renderer:
    """Draws a simulation into pygame surfaces in one of the colour modes."""

    def __init__(self, sim: Simulation, size: tuple[int, int], mode: str = "speed"):
        import pygame

        self.pygame = pygame
        self.sim = sim
        self.mode = mode
        self.font = pygame.font.Font(None, 20)
        self.resize(size)
        scene = sim.scene
        g = float(np.hypot(*scene.gravity))
        height = scene.domain_max[1] - scene.domain_min[1]
        self.vmax = float(np.sqrt(2 * g * height)) if g > 0 else 1.0
        # Pressure scale: the hydrostatic head, or Laplace's sigma/R of the
        # smallest fluid region (a drop in zero gravity), whichever is larger.
        laplace = 0.0
        if scene.surface_tension > 0 and scene.regions:
            sizes = [min(x1 - x0, y1 - y0) for (x0, y0), (x1, y1) in
                     (r.bounds() for r in scene.regions)]
            laplace = scene.surface_tension / max(0.5 * min(sizes), 1e-9)
        self.pmax = max(1.0, scene.rest_density * g * height, 2 * laplace)  # Pa

    def resize(self, size: tuple[int, int]) -> None:
        """Fit the domain into a window of this size (also resets zoom and pan)."""
        self.size = size
        self.camera = Camera(self.sim.scene, size)
        self.pixels = np.empty((size[0], size[1]), np.uint32)  # packed 0xRRGGBB
        self._surface_cache = None

    # -- scalar fields and their colour scales
    def field(self) -> tuple[np.ndarray, np.ndarray, float, float]:
        """(values, ramp, low, high) of the current scalar mode."""
        sim = self.sim
        if self.mode == "pressure":
            return sim.pressures / 1000.0, DIVERGING, -self.pmax / 1000.0, self.pmax / 1000.0
        if self.mode == "density":
            err = 100.0 * (sim.densities / sim.scene.rest_density - 1.0)
            return err, DIVERGING, -10.0, 10.0
        speed = np.sqrt((sim.velocities**2).sum(axis=1))
        return speed, SEQUENTIAL, 0.0, self.vmax

    def draw(self, surface) -> None:
        if self.mode == "surface":
            self.draw_surface(surface)
        else:
            self.pixels.fill(pack(BACKGROUND))
            values, lut, low, high = self.field()
            t = np.clip((values - low) / (high - low), 0.0, 1.0)
            self.splat_dots(pack(lut)[(t * (len(lut) - 1)).astype(np.int64)])
            self.pygame.surfarray.blit_array(surface, self.pixels)
        for a, b in self.sim.scene.walls:
            (sx, sy) = self.camera.to_screen(np.array([a, b]))
            self.pygame.draw.line(surface, WALL, (sx[0], sy[0]), (sx[1], sy[1]), 2)
        if self.mode != "surface":
            self.draw_colour_bar(surface)

    def screen_points(self) -> tuple[np.ndarray, np.ndarray]:
        sx, sy = self.camera.to_screen(self.sim.positions)
        return np.rint(sx).astype(np.int64), np.rint(sy).astype(np.int64)

    def splat_dots(self, colour: np.ndarray) -> None:
        """Each particle as a small disc of its colour: one flat-index write per
        disc offset, with points clamped so no offset leaves the buffer."""
        if self.sim.n_particles == 0:
            return
        ix, iy = self.screen_points()
        w, h = self.size
        radius = min(max(0, round(0.5 * self.sim.scene.spacing * self.camera.scale)),
                     (min(w, h) - 1) // 2)
        visible = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
        if not visible.all():
            ix, iy, colour = ix[visible], iy[visible], colour[visible]
        base = np.clip(ix, radius, w - 1 - radius) * h + np.clip(iy, radius, h - 1 - radius)
        flat = self.pixels.reshape(-1)
        for dx in range(-radius, radius + 1):
            for dy in range(-radius, radius + 1):
                if dx * dx + dy * dy <= radius * radius + radius:
                    flat[base + (dx * h + dy)] = colour

    def draw_surface(self, surface) -> None:
        """The liquid as a smooth body: particles binned on a grid of about one
        spacing, blurred, thresholded at a third of the bulk coverage, shaded by
        depth below the surface, then scaled up onto the whole window."""
        pg = self.pygame
        w, h = self.size
        if self.sim.n_particles == 0:
            surface.fill(BACKGROUND)
            return
        cell = max(1.0, self.sim.scene.spacing * self.camera.scale)  # pixels
        gw, gh = max(1, round(w / cell)), max(1, round(h / cell))
        cx, cy = w / gw, h / gh  # exact cell size, so the scaled image lines up
        sx, sy = self.camera.to_screen(self.sim.positions)
        gx, gy = (sx / cx).astype(np.int64), (sy / cy).astype(np.int64)
        ok = (gx >= 0) & (gx < gw) & (gy >= 0) & (gy < gh)
        grid = np.bincount(gx[ok] * gh + gy[ok], minlength=gw * gh).reshape(gw, gh)
        grid = blur(grid.astype(np.float32))
        inside = grid > 0.35  # in the bulk a cell holds about one particle
        # Darker with depth below the nearest surface above: the run of liquid
        # cells counted from the top, restarting below every gap.
        count = np.cumsum(inside, axis=1, dtype=np.int32)
        depth = count - np.maximum.accumulate(np.where(inside, 0, count), axis=1)
        # Shade index: 0 at the surface, the last shade half a metre down.
        cap = max(1, int(np.ceil(0.5 * self.camera.scale / cy)))
        level = np.minimum(depth, cap)
        level[inside & ~np.roll(inside, 1, axis=1)] = cap + 1  # a bright rim on top
        level[~inside] = cap + 2
        if self._surface_cache is None or self._surface_cache[0] != (gw, gh, cap):
            packed = pack(SURFACE_LUT)
            lut = np.concatenate([packed[np.linspace(0, 255, cap + 1).astype(int)],
                                  packed[256:]])
            self._surface_cache = ((gw, gh, cap), pg.Surface((gw, gh), depth=32), lut)
        _, small, lut = self._surface_cache
        pg.surfarray.blit_array(small, np.take(lut, level))
        pg.transform.scale(small, (w, h), surface)  # nearest: cells are a few pixels

    def draw_colour_bar(self, surface) -> None:
        _, lut, low, high = self.field()
        pg = self.pygame
        x0, y0, bw, bh = self.size[0] - 60, 40, 14, max(40, self.size[1] - 120)
        bar = np.repeat(lut[::-1][np.linspace(0, len(lut) - 1, bh).astype(int)][None, :, :], bw,
                        axis=0)
        surface.blit(pg.surfarray.make_surface(bar), (x0, y0))
        for frac, val in ((0.0, high), (0.5, 0.5 * (low + high)), (1.0, low)):
            label = self.font.render(f"{val:.3g}", True, TEXT)
            surface.blit(label, (x0 + bw + 4, y0 + frac * (bh - 1) - 7))
        unit = {"speed": "m/s", "pressure": "kPa", "density": "% rho0"}[self.mode]
        title = self.font.render(unit, True, DIM)
        surface.blit(title, (x0, y0 - 16))


class Editor:
    """The terrain tools, in screen coordinates: draw and delete walls, pour, push."""

    SNAP_PX = 12  # end points this close to an existing one snap onto it
    PICK_PX = 10  # a wall this close to the cursor is the one under it
    EMIT_SPEED = 1.0  # m/s, straight down

    def __init__(self, sim: Simulation, renderer: Renderer):
        self.sim = sim
        self.renderer = renderer
        self.start: tuple[float, float] | None = None  # a wall being drawn (world, m)
        self.emitter: tuple[float, float] | None = None
        self.last_emit = -np.inf

    def world(self, px: float, py: float) -> tuple[float, float]:
        return self.renderer.camera.to_world(px, py)

    def snap(self, px: float, py: float) -> tuple[float, float]:
        """World point under the pixel, snapped to a wall end point within SNAP_PX."""
        ends = [p for seg in self.sim.scene.walls for p in seg]
        if ends:
            sx, sy = self.renderer.camera.to_screen(np.asarray(ends))
            d = np.hypot(sx - px, sy - py)
            i = int(np.argmin(d))
            if d[i] <= self.SNAP_PX:
                return tuple(map(float, ends[i]))
        return self.world(px, py)

    def begin_wall(self, px: float, py: float) -> None:
        self.start = self.snap(px, py)

    def end_wall(self, px: float, py: float) -> bool:
        """Finish the wall being drawn; True if one was added."""
        if self.start is None:
            return False
        a, b = self.start, self.snap(px, py)
        self.start = None
        sa = np.array(self.renderer.camera.to_screen(np.asarray(a)))
        sb = np.array(self.renderer.camera.to_screen(np.asarray(b)))
        if np.hypot(*(sa - sb)) < 4:  # a click, not a drag
            return False
        self.sim.add_wall(a, b)
        return True

    def wall_at(self, px: float, py: float) -> int | None:
        walls = self.sim.scene.walls
        if not walls:
            return None
        seg = np.asarray(walls, float)
        sx, sy = self.renderer.camera.to_screen(seg)
        a = np.stack([sx[:, 0], sy[:, 0]], axis=1)
        b = np.stack([sx[:, 1], sy[:, 1]], axis=1)
        ab = b - a
        t = np.clip(((np.array([px, py]) - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-12),
                    0.0, 1.0)
        d = np.hypot(*(a + t[:, None] * ab - [px, py]).T)
        i = int(np.argmin(d))
        return i if d[i] <= self.PICK_PX else None

    def delete_wall_at(self, px: float, py: float) -> bool:
        i = self.wall_at(px, py)
        if i is None:
            return False
        self.sim.remove_wall(i)
        return True

    def toggle_emitter(self, px: float, py: float) -> None:
        self.emitter = None if self.emitter else self.world(px, py)
        self.last_emit = -np.inf

    def emit(self) -> int:
        """Pour a row of three particles whenever the last row has moved one spacing."""
        if self.emitter is None:
            return 0
        dx = self.sim.scene.spacing
        if self.sim.time - self.last_emit < dx / self.EMIT_SPEED:
            return 0
        self.last_emit = self.sim.time
        x0, y0 = self.emitter
        pos = np.array([[x0 + i * dx, y0] for i in (-1, 0, 1)])
        self.sim.add_particles(pos, np.tile([0.0, -self.EMIT_SPEED], (3, 1)))
        return 3

    def push(self, px: float, py: float, dpx: float, dpy: float) -> None:
        """Drag fluid near the cursor along with it: a smooth weight (1 - r^2/R^2)^2
        blends each velocity towards the cursor's, R = 5 spacings."""
        if self.sim.n_particles == 0:
            return
        scale = self.renderer.camera.scale
        centre = np.array(self.world(px, py))
        radius = 5 * self.sim.scene.spacing
        x, v = self.sim.positions, self.sim.velocities
        r2 = ((x - centre) ** 2).sum(axis=1) / radius**2
        near = r2 < 1.0
        if not near.any():
            return
        # The cursor's velocity: its move this frame over one frame of real time.
        target = np.array([dpx, -dpy]) / scale * TARGET_FPS
        w = ((1.0 - r2[near]) ** 2)[:, None]
        v = v.copy()
        v[near] += w * (target - v[near])
        self.sim.set_state(x.copy(), v, self.sim.ids.copy())


def pack(rgb) -> np.ndarray:
    """RGB triples (..., 3) as packed 0xRRGGBB integers, the layout of pygame's
    32-bit surfaces used here."""
    rgb = np.asarray(rgb, np.uint32)
    return (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]


def blur(grid: np.ndarray) -> np.ndarray:
    """A separable binomial [1 4 6 4 1]/16 blur along both axes, by shifted slices."""
    n, m = grid.shape
    g = np.pad(grid, ((2, 2), (0, 0)))
    grid = (g[0:n] + g[4:n + 4] + 4 * (g[1:n + 1] + g[3:n + 3]) + 6 * g[2:n + 2]) / 16
    g = np.pad(grid, ((0, 0), (2, 2)))
    return (g[:, 0:m] + g[:, 4:m + 4] + 4 * (g[:, 1:m + 1] + g[:, 3:m + 3])
            + 6 * g[:, 2:m + 2]) / 16


def save_scene(sim: Simulation, path: Path) -> Path:
    """Write the simulation's scene (walls and parameters) as JSON that loads again."""
    data = sim.scene.to_dict()
    path.write_text(json.dumps(data, indent=2) + "\n")
    load_scene(path)  # refuse to leave a file behind that does not load
    return path


def view(scene_path: str | Path | Scene, *, frames: int | None = None,
         screenshot: str | Path | None = None, steps_per_frame: int | None = None,
         size: tuple[int, int] = (1000, 700), threads: int | None = None,
         mode: str = "speed", script=None) -> int:
    """Open the window and run until closed (or for ``frames`` frames). Returns 0.

    script(frame, pygame, sim), if given, runs at the start of every frame (to
    post events in tests and demos).
    """
    import os

    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    scene = scene_path if isinstance(scene_path, Scene) else load_scene(scene_path)
    sim = Simulation(scene, threads=threads)
    pygame.display.init()  # not pygame.init(): no audio device is needed
    pygame.font.init()
    try:
        window = _Window(pygame, sim, size, mode, steps_per_frame)
        clock = pygame.time.Clock()
        frame = 0
        while window.running:
            if script is not None:
                script(frame, pygame, sim)
            window.frame(clock.get_fps())
            frame += 1
            if frames is not None and frame >= frames:
                window.running = False
            clock.tick(TARGET_FPS)
        if screenshot is not None:
            pygame.image.save(window.screen, str(screenshot))
    finally:
        pygame.quit()
    return 0


class _Window:
    """The live window between frames: what runs, what shows, and the last message.

    A frame handles the pending events, steps the simulation and draws.
    """

    def __init__(self, pygame, sim: Simulation, size: tuple[int, int], mode: str,
                 steps_per_frame: int | None):
        self.pygame = pygame
        self.sim = sim
        scene = sim.scene
        self.stem = Path(scene.source).stem if scene.source else "scene"  # of saved files
        self.size = size
        self.screen = pygame.display.set_mode(size, pygame.RESIZABLE)
        pygame.display.set_caption(f"sphfluid - {scene.name or 'scene'}")
        self.renderer = Renderer(sim, size, mode)
        self.editor = Editor(sim, self.renderer)
        # Steps per frame: real time at TARGET_FPS, within STEP_BUDGET, until
        # + or - (or --steps-per-frame) fixes the count.
        self.realtime = max(1, round(1.0 / (TARGET_FPS * (scene.time_step or 1e-3))))
        self.adaptive = steps_per_frame is None
        self.n_steps = self.realtime if steps_per_frame is None else steps_per_frame
        self.step_rate = 0.0  # steps/s of the last frame's stepping
        self.draw_ms = 0.0
        self.paused = self.show_help = self.single = False
        self.message = ""
        self.shots = 0
        self.running = True
        self.cursor = pygame.mouse.get_pos()

    def frame(self, fps: float) -> None:
        self.single = False
        for event in self.pygame.event.get():
            self.on_event(event)
        self.step()
        self.draw(fps)
        self.pygame.display.flip()

    # -- events
    def on_event(self, event) -> None:
        pg, editor, camera = self.pygame, self.editor, self.renderer.camera
        if event.type == pg.QUIT:
            self.running = False
        elif event.type == pg.VIDEORESIZE:
            self.size = (max(200, event.w), max(150, event.h))
            self.screen = pg.display.set_mode(self.size, pg.RESIZABLE)
            self.renderer.resize(self.size)
        elif event.type == pg.MOUSEBUTTONDOWN and event.button == 1:
            editor.begin_wall(*event.pos)
        elif event.type == pg.MOUSEBUTTONUP and event.button == 1:
            try:
                if editor.end_wall(*event.pos):
                    self.message = f"wall added ({len(self.sim.scene.walls)} walls)"
            except ValueError as e:
                self.message = f"wall not added: {e}"
        elif event.type == pg.MOUSEWHEEL:
            camera.zoom(1.25 ** event.y, *self.cursor)
        elif event.type == pg.MOUSEMOTION:
            self.cursor = event.pos
            if event.buttons[2]:
                editor.push(event.pos[0], event.pos[1], *event.rel)
            elif event.buttons[1]:
                camera.pan(*event.rel)
        elif event.type == pg.KEYDOWN:
            self.on_key(event.key, bool(event.mod & pg.KMOD_CTRL))

    def on_key(self, key: int, ctrl: bool) -> None:
        """The keys of HELP."""
        pg, sim, editor = self.pygame, self.sim, self.editor
        if key in (pg.K_ESCAPE, pg.K_q):
            self.running = False
        elif key == pg.K_s and ctrl:
            self.message = f"saved {save_scene(sim, Path(f'{self.stem}_saved.json'))}"
        elif key == pg.K_SPACE:
            self.paused = not self.paused
        elif key in (pg.K_s, pg.K_RIGHT):
            self.single = self.paused = True
        elif key == pg.K_r:
            sim.reset()
            self.message = ""
        elif key in (pg.K_PLUS, pg.K_EQUALS, pg.K_KP_PLUS):
            self.adaptive, self.n_steps = False, self.n_steps * 2
        elif key in (pg.K_MINUS, pg.K_KP_MINUS):
            self.adaptive, self.n_steps = False, max(1, self.n_steps // 2)
        elif key in (pg.K_1, pg.K_2, pg.K_3, pg.K_4):
            self.renderer.mode = MODES[key - pg.K_1]
        elif key == pg.K_h:
            self.show_help = not self.show_help
        elif key == pg.K_0:
            self.renderer.resize(self.size)  # fit the domain again
        elif key in (pg.K_x, pg.K_DELETE):
            if editor.delete_wall_at(*self.cursor):
                self.message = f"wall deleted ({len(sim.scene.walls)} walls)"
        elif key == pg.K_e:
            editor.toggle_emitter(*self.cursor)
            self.message = "pouring" if editor.emitter else "pouring stopped"
        elif key == pg.K_p:
            self.shots += 1
            name = f"{self.stem}_{self.shots:03d}.png"
            pg.image.save(self.screen, name)
            self.message = f"saved {name}"

    # -- stepping
    def step(self) -> None:
        """This frame's steps: one after S, none while paused or unstable, else n_steps."""
        sim = self.sim
        unstable = self.message.startswith("unstable")
        todo = 1 if self.single else (0 if self.paused or unstable else self.n_steps)
        if not todo:
            return
        self.editor.emit()
        t0 = time.perf_counter()
        try:
            sim.step(todo)
        except InstabilityError as e:
            self.message = f"unstable: {e} ({sim.instability_advice(e)})"
            self.paused = True
        self.step_rate = todo / max(time.perf_counter() - t0, 1e-9)
        if sim.adaptive and sim.dt > 0:
            self.realtime = max(1, round(1.0 / (TARGET_FPS * sim.dt)))
        if self.adaptive and not self.single:
            self.n_steps = max(1, min(self.realtime, int(STEP_BUDGET * self.step_rate)))

    # -- drawing
    def draw(self, fps: float) -> None:
        """The particles and walls, the tools in use, then the text."""
        pg, screen, camera, editor = self.pygame, self.screen, self.renderer.camera, self.editor
        t0 = time.perf_counter()
        self.renderer.draw(screen)
        self.draw_ms = 1000 * (time.perf_counter() - t0)
        if editor.start is not None:  # the wall being drawn
            a = camera.to_screen(np.asarray(editor.start))
            pg.draw.line(screen, (255, 210, 90), a, self.cursor, 2)
        if editor.emitter is not None:
            e = camera.to_screen(np.asarray(editor.emitter))
            pg.draw.circle(screen, (255, 210, 90), (int(e[0]), int(e[1])), 6, 2)
        font = self.renderer.font
        screen.blit(font.render(self.status(fps), True, TEXT), (8, 5))
        wx, wy = camera.to_world(*self.cursor)
        footer = (f"{MODE_LABELS[self.renderer.mode]}   draw {self.draw_ms:.1f} ms   cursor "
                  f"({wx:.3f}, {wy:.3f}) m   H: help")
        screen.blit(font.render(footer, True, DIM), (8, self.size[1] - 18))
        if self.message:
            screen.blit(font.render(self.message[:170], True, (255, 140, 120)), (8, 24))
        if self.show_help:
            for i, line in enumerate(HELP):
                screen.blit(font.render(line, True, TEXT), (30, 60 + 20 * i))

    def status(self, fps: float) -> str:
        """The top line: time, speed, particles, compression, step and method."""
        sim = self.sim
        st = sim.stats()
        return (f"t = {sim.time:7.3f} s  {fps:5.1f} fps  {self.step_rate:7,.0f} "
                f"steps/s  {sim.n_particles:,} particles ({sim.removed_particles} removed)"
                f"  max compression {100 * st['max_compression']:.1f} %  dt "
                f"{sim.dt:.2e} s ({sim.dt_limit})  {sim.scene.method}"
                + (" (float pairs)" if st["pair_precision"] == "float" else "")
                + f"  {self.n_steps} steps/frame"
                + ("  PAUSED" if self.paused else ""))


def record(scene_path: str | Path, out: Path, *, duration: float | None = None,
           fps: float = 30.0, mode: str = "speed", size: tuple[int, int] = (800, 600),
           threads: int | None = None, progress=None) -> int:
    """Render frames headless: a folder of PNGs, or an animated GIF (needs Pillow).

    Returns the number of frames written.
    """
    import os

    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    scene = load_scene(scene_path)
    duration = duration if duration is not None else scene.duration
    if duration is None:
        raise ValueError("no duration given and the scene has no 'duration'")
    gif = out.suffix.lower() == ".gif"
    if gif:
        try:
            from PIL import Image
        except ImportError:
            raise ValueError("writing a GIF needs Pillow (pip install pillow); "
                             "or give a folder to write PNG frames") from None
    elif out.suffix:
        raise ValueError(f"--out: expected a folder for PNG frames or a .gif file, got {out}")
    sim = Simulation(scene, threads=threads)
    pygame.display.init()
    pygame.font.init()
    try:
        surface = pygame.Surface(size)
        renderer = Renderer(sim, size, mode)
        n_frames = int(duration * fps + 1e-9) + 1
        images = []
        if not gif:
            out.mkdir(parents=True, exist_ok=True)
        for k in range(n_frames):
            sim.advance_to(k / fps)
            surface.fill(BACKGROUND)
            renderer.draw(surface)
            label = renderer.font.render(f"t = {sim.time:.3f} s", True, TEXT)
            surface.blit(label, (8, 5))
            if gif:
                raw = pygame.image.tostring(surface, "RGB")
                images.append(Image.frombytes("RGB", size, raw))
            else:
                pygame.image.save(surface, str(out / f"frame_{k:05d}.png"))
            if progress:
                progress(k + 1, n_frames, sim)
        if gif:
            images[0].save(out, save_all=True, append_images=images[1:],
                           duration=round(1000 / fps), loop=0)
    finally:
        pygame.quit()
    return n_frames
