"""A pygame window that runs a scene live: particles coloured by speed, walls, status.

pygame is imported inside ``view`` so that ``import sphfluid`` and headless runs
never need it or a display. Particles are drawn in bulk from numpy arrays into a
pixel buffer, never one Python call per particle.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from .scene import Scene, load_scene
from .simulation import InstabilityError, Simulation

BACKGROUND = (18, 20, 28)
WALL = (225, 225, 225)
TEXT = (235, 235, 235)
TARGET_FPS = 60
STEP_BUDGET = 0.030  # seconds of stepping per frame before slowing below real time


def speed_colours(n: int = 256) -> np.ndarray:
    """A (n, 3) uint8 colour ramp from slow (deep blue) to fast (white)."""
    stops = np.array([[20, 60, 160], [30, 130, 220], [60, 200, 230], [180, 240, 250],
                      [255, 255, 255]], float)
    t = np.linspace(0, len(stops) - 1, n)
    i = np.minimum(t.astype(int), len(stops) - 2)
    f = (t - i)[:, None]
    return (stops[i] * (1 - f) + stops[i + 1] * f).astype(np.uint8)


class _Camera:
    """Maps world coordinates (m, y up) to pixels (y down), fitting the domain."""

    def __init__(self, scene: Scene, size: tuple[int, int], margin: int = 10, top: int = 24,
                 bottom: int = 20):
        (x0, y0), (x1, y1) = scene.domain_min, scene.domain_max
        w, h = size
        free_h = h - 2 * margin - top - bottom
        self.scale = min((w - 2 * margin) / (x1 - x0), free_h / (y1 - y0))
        self.ox = margin + 0.5 * ((w - 2 * margin) - self.scale * (x1 - x0)) - self.scale * x0
        self.oy = top + margin + 0.5 * (free_h - self.scale * (y1 - y0)) + self.scale * y1

    def to_screen(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return (self.ox + self.scale * xy[..., 0], self.oy - self.scale * xy[..., 1])


def draw_particles(pixels: np.ndarray, sim: Simulation, cam: _Camera, lut: np.ndarray,
                   vmax: float) -> None:
    """Splat every particle as a small disc of its speed colour into pixels (W, H, 3)."""
    pos = sim.positions
    if len(pos) == 0:
        return
    sx, sy = cam.to_screen(pos)
    ix = np.rint(sx).astype(np.int64)
    iy = np.rint(sy).astype(np.int64)
    speed = np.sqrt((sim.velocities**2).sum(axis=1))
    colour = lut[np.minimum((speed / vmax * (len(lut) - 1)).astype(np.int64), len(lut) - 1)]
    radius = max(0, int(round(0.5 * sim.scene.spacing * cam.scale)))
    w, h = pixels.shape[:2]
    for dx in range(-radius, radius + 1):
        for dy in range(-radius, radius + 1):
            if dx * dx + dy * dy > radius * radius + radius:
                continue
            x = ix + dx
            y = iy + dy
            ok = (x >= 0) & (x < w) & (y >= 0) & (y < h)
            pixels[x[ok], y[ok]] = colour[ok]


def view(scene_path: str | Path | Scene, *, frames: int | None = None,
         screenshot: str | Path | None = None, steps_per_frame: int | None = None,
         size: tuple[int, int] = (1000, 700), threads: int | None = None) -> int:
    """Open the window and run until closed (or for ``frames`` frames). Returns 0."""
    import os

    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    scene = scene_path if isinstance(scene_path, Scene) else load_scene(scene_path)
    sim = Simulation(scene, threads=threads)
    pygame.display.init()  # not pygame.init(): no audio device is needed
    pygame.font.init()
    try:
        screen = pygame.display.set_mode(size)
        pygame.display.set_caption(f"sphfluid - {scene.name or 'scene'}")
        font = pygame.font.Font(None, 20)
        cam = _Camera(scene, size)
        lut = speed_colours()
        g = float(np.hypot(*scene.gravity))
        height = scene.domain_max[1] - scene.domain_min[1]
        vmax = max(1e-6, float(np.sqrt(2 * g * height)) if g > 0 else 1.0)
        # Real time: the scene's dt, or for "auto" a first guess refined as it runs.
        realtime = max(1, round(1.0 / (TARGET_FPS * (scene.time_step or 1e-3))))
        adaptive = steps_per_frame is None
        n_steps = realtime if adaptive else steps_per_frame
        walls = [cam.to_screen(np.asarray(w)) for w in scene.walls]
        pixels = np.empty((size[0], size[1], 3), np.uint8)
        clock = pygame.time.Clock()
        paused = False
        message = ""
        frame = 0
        step_rate = 0.0
        running = True
        while running:
            single = False
            for event in pygame.event.get():
                if event.type == pygame.QUIT:
                    running = False
                elif event.type == pygame.KEYDOWN:
                    if event.key in (pygame.K_ESCAPE, pygame.K_q):
                        running = False
                    elif event.key == pygame.K_SPACE:
                        paused = not paused
                    elif event.key in (pygame.K_s, pygame.K_RIGHT):
                        single, paused = True, True
                    elif event.key == pygame.K_r:
                        sim.reset()
                        message = ""
            todo = 1 if single else (0 if paused or message else n_steps)
            if todo:
                t0 = time.perf_counter()
                try:
                    sim.step(todo)
                except InstabilityError as e:
                    message = f"unstable: {e}"
                    paused = True
                elapsed = time.perf_counter() - t0
                step_rate = todo / max(elapsed, 1e-9)
                if sim.adaptive and sim.dt > 0:
                    realtime = max(1, round(1.0 / (TARGET_FPS * sim.dt)))
                if adaptive and not single:
                    n_steps = max(1, min(realtime, int(STEP_BUDGET * step_rate)))
            pixels[:] = BACKGROUND
            draw_particles(pixels, sim, cam, lut, vmax)
            pygame.surfarray.blit_array(screen, pixels)
            for sx, sy in walls:
                pygame.draw.line(screen, WALL, (sx[0], sy[0]), (sx[1], sy[1]), 2)
            status = (f"t = {sim.time:7.3f} s   {clock.get_fps():5.1f} fps   "
                      f"{step_rate:8,.0f} steps/s   {sim.n_particles:,} particles   "
                      f"{n_steps} steps/frame   dt {sim.dt:.2e} s ({sim.dt_limit})"
                      + ("   PAUSED" if paused else ""))
            screen.blit(font.render(status, True, TEXT), (8, 5))
            keys = "space pause   S / right: one step   R reset   Q quit"
            screen.blit(font.render(keys, True, (150, 150, 160)), (8, size[1] - 18))
            if message:
                screen.blit(font.render(message[:160], True, (255, 120, 120)), (8, 24))
            pygame.display.flip()
            frame += 1
            if frames is not None and frame >= frames:
                running = False
            clock.tick(TARGET_FPS)
        if screenshot is not None:
            pygame.image.save(screen, str(screenshot))
    finally:
        pygame.quit()
    return 0
