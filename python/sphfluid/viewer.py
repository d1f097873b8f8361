"""A pygame window that runs a scene live, and headless frame recording.

pygame is imported inside the functions so that ``import sphfluid`` and headless
runs never need it or a display. Everything per particle is drawn in bulk from
numpy arrays into a pixel buffer, never one Python call per particle.
"""
from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from .flows import DampingZone, Emitter, Outlet, WallMotion
from .scene import Region, Scene, SceneError, load_scene
from .simulation import InstabilityError, Simulation
from .surface import polygons as liquid_polygons

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
    "I / O  the next left-drag places an inlet / outlet (flow to the drag's right)",
    "K  the next left-drag places a sink (a rectangle)",
    "B  the next left-drag places a damping zone (from where it begins to full strength)",
    "X or Delete  delete the wall (or sink, inlet, outlet, zone) under the cursor",
    "M  the wall under the cursor moves to and fro along its normal (a paddle); again: stops",
    "   (drawing or deleting a wall fixes every wall where it was drawn)",
    "E  start / stop pouring at the cursor (an emitter Ctrl+S saves)",
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
LIQUID = (40, 110, 200)  # the liquid mode's body
RIM = (180, 230, 255)  # and its surface
PROBE = (255, 170, 40)  # the scene's probes
EMITTER = (120, 230, 255)  # the scene's emitters
SINK = (235, 90, 200)  # the scene's sinks
DAMPING = (90, 200, 235)  # the scene's damping zones
SMOOTH_FINE = 10_000  # particles up to which the liquid's grid is half a spacing
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


def level_line(ring: np.ndarray, gravity, level: float | None) -> np.ndarray | None:
    """Where an outlet's held level (m along -g) crosses its buffer (the
    polygon ring, (4, 2)): the two ends (2, 2), or None (no level, no gravity,
    or the level above or below the buffer)."""
    g = np.asarray(gravity, float)
    if level is None or not np.hypot(*g) > 0:
        return None
    z = ring @ (-g / np.hypot(*g)) - level  # each corner's height above the level
    ends = [ring[k] + z[k] / (z[k] - z[k - 1]) * (ring[k - 1] - ring[k])
            for k in range(len(ring)) if (z[k] > 0) != (z[k - 1] > 0)]
    return np.array(ends[:2]) if len(ends) >= 2 else None


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
        for a, b in self.sim.walls:  # where they are now (moving walls move)
            (sx, sy) = self.camera.to_screen(np.array([a, b]))
            self.pygame.draw.line(surface, WALL, (sx[0], sy[0]), (sx[1], sy[1]), 2)
        self.draw_flows(surface)
        self.draw_probes(surface)
        if self.mode != "surface":
            self.draw_colour_bar(surface)

    def draw_flows(self, surface) -> None:
        """The sinks and the outlets' and inlets' buffers, outlined, the damping
        zones (where they begin and where they reach full strength), and the
        emitters and inlets: each nozzle's row as a bar with an arrow along the
        jet, bright while it emits, dim before its start and after its stop."""
        pg, cam, scene = self.pygame, self.camera, self.sim.scene
        lo, hi = scene.domain_min, scene.domain_max
        for z in scene.damping_zones:
            full = dataclasses.replace(z, start=z.end,
                                       end=tuple(2 * np.asarray(z.end) - z.start))
            for ring in (z.region(lo, hi), full.region(lo, hi)):
                if len(ring) >= 3:
                    pg.draw.polygon(surface, DAMPING,
                                    self.screen_ring(np.vstack([ring, ring[:1]])), 1)
        for ring in self.sink_rings():
            pg.draw.polygon(surface, SINK, self.screen_ring(np.vstack([ring, ring[:1]])), 2)
        t, dx = self.sim.time, scene.spacing
        if scene.inlets or scene.outlets:
            self.draw_buffers(surface)
        for e in (*scene.emitters, *scene.inlets):
            on = e.start <= t and (e.stop is None or t < e.stop)
            colour = EMITTER if on else tuple(c // 2 for c in EMITTER)
            row = e.row(dx)
            d = e.unit()
            across = np.array([-d[1], d[0]]) * 0.5 * dx
            ends = np.array([row[0] - across, row[-1] + across])
            sx, sy = cam.to_screen(ends)
            pg.draw.line(surface, colour, (sx[0], sy[0]), (sx[1], sy[1]), 4)
            tip = np.asarray(e.at) + 3 * dx * d
            arrow = np.array([e.at, tip, tip - dx * d + across * 2, tip, tip - dx * d - across * 2])
            ax, ay = cam.to_screen(arrow)
            pg.draw.lines(surface, colour, False, list(zip(ax, ay)), 2)

    def draw_buffers(self, surface) -> None:
        """The inlets' and outlets' buffers outlined, an outlet's held level as a
        line across its buffer."""
        pg, scene = self.pygame, self.sim.scene
        depth = scene.buffer_depth()
        zones = [e.zone(scene.spacing, depth) for e in scene.inlets]
        for ring in zones + [o.zone(depth) for o in scene.outlets]:
            pg.draw.polygon(surface, SINK, self.screen_ring(np.vstack([ring, ring[:1]])), 1)
        for o in scene.outlets:
            ends = level_line(o.zone(depth), scene.gravity, o.level)
            if ends is not None:
                sx, sy = self.camera.to_screen(ends)
                pg.draw.line(surface, SINK, (sx[0], sy[0]), (sx[1], sy[1]), 2)

    def sink_rings(self) -> list:
        """The scene's sinks as closed outlines (k, 2) in world coordinates."""
        rings = []
        for r in self.sim.scene.sinks:
            if r.shape == "circle":
                (cx, cy), = r.points
                rings.append(np.array([[cx + r.radius * np.cos(a), cy + r.radius * np.sin(a)]
                                       for a in np.linspace(0, 2 * np.pi, 48, endpoint=False)]))
            elif r.shape == "rectangle":
                (x0, y0), (x1, y1) = r.points
                rings.append(np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]]))
            else:
                rings.append(np.asarray(r.points, float))
        return rings

    def draw_probes(self, surface) -> None:
        """The scene's probes, named: a ring at each point, a dashed vertical line
        for each surface-height line, and each wall group drawn over its walls."""
        probes = self.sim.scene.probes
        if probes is None:
            return
        pg, cam = self.pygame, self.camera
        labels = []
        walls = self.sim.walls
        for w in probes.walls:
            mid = []
            for k in w.segments:
                if k < len(walls):  # (the editor may have removed walls since)
                    sx, sy = cam.to_screen(np.array(walls[k]))
                    pg.draw.line(surface, PROBE, (sx[0], sy[0]), (sx[1], sy[1]), 4)
                    mid.append((sx.mean(), sy.mean()))
            if mid:
                labels.append((w.name, *mid[len(mid) // 2]))
        y0, y1 = self.sim.scene.domain_min[1], self.sim.scene.domain_max[1]
        for line in probes.surface:
            sx, sy = cam.to_screen(np.array([[line.x, y0], [line.x, y1]]))
            x, dash = round(float(sx[0])), 6
            for top in range(round(float(sy[1])), round(float(sy[0])), 2 * dash):
                pg.draw.line(surface, PROBE, (x, top), (x, min(top + dash, sy[0])), 1)
            labels.append((line.name, x, sy[1] + 8))
        for point in probes.points:
            sx, sy = cam.to_screen(np.array([point.at]))
            centre = (round(float(sx[0])), round(float(sy[0])))
            pg.draw.circle(surface, BACKGROUND, centre, 7, 2)
            pg.draw.circle(surface, PROBE, centre, 5, 2)
            labels.append((point.name, *centre))
        for name, x, y in labels:  # on a dark box, readable over any colour
            text = self.font.render(name, True, PROBE)
            box = pg.Surface((text.get_width() + 4, text.get_height() + 2), pg.SRCALPHA)
            box.fill((*BACKGROUND, 190))
            surface.blit(box, (x + 5, y - 8))
            surface.blit(text, (x + 7, y - 7))

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
        """The liquid as a smooth body: the outline of ``sphfluid.surface`` (the
        kernel sum's level 0.5 by marching squares, on a grid of half a spacing,
        a whole one above SMOOTH_FINE particles, coarser when zoomed out so a
        cell stays above 1.5 pixels), filled, with its holes, and edged with an
        anti-aliased rim."""
        from pygame import gfxdraw

        surface.fill(BACKGROUND)
        if self.sim.n_particles == 0:
            return
        fine = 0.5 if self.sim.n_particles <= SMOOTH_FINE else 1.0
        cell = max(fine * self.sim.scene.spacing, 1.5 / self.camera.scale)
        for outline, holes in liquid_polygons(self.sim, cell):
            rings = [(self.screen_ring(outline), LIQUID)]
            rings += [(self.screen_ring(hole), BACKGROUND) for hole in holes]
            for ring, colour in rings:
                if len(ring) >= 3:
                    gfxdraw.filled_polygon(surface, ring, colour)
            for ring, _ in rings:
                if len(ring) >= 2:
                    self.pygame.draw.aalines(surface, RIM, True, ring)

    def screen_ring(self, ring: np.ndarray) -> list[tuple[int, int]]:
        """A ring's points in pixels, clamped to the 16-bit range pygame draws in."""
        sx, sy = self.camera.to_screen(ring[:-1])  # a closed ring repeats its first point
        xy = np.clip(np.rint(np.column_stack([sx, sy])), -30000, 30000).astype(np.int64)
        return [tuple(p) for p in xy.tolist()]

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
    """The terrain tools, in screen coordinates: draw and delete walls, pour,
    push; place and delete sinks, inlets, outlets and damping zones."""

    SNAP_PX = 12  # end points this close to an existing one snap onto it
    PICK_PX = 10  # a wall this close to the cursor is the one under it
    EMIT_SPEED = 1.0  # m/s, straight down
    INFLOW_SPEED = 0.5  # m/s, an inlet placed here (the saved scene can change it)
    # M: a wall oscillates along its normal, a spacing either way, for this many
    # periods from now (ramped up over the first), then rests where it started.
    PADDLE_PERIOD, PADDLE_PERIODS = 1.0, 20
    # What the next left-drag places (the keys of HELP), then walls again.
    TOOLS = ("wall", "inlet", "outlet", "sink", "damping zone")
    HINTS = {"wall": "left-drag draws walls",
             "inlet": "drag the inlet's line: the fluid enters towards the drag's right",
             "outlet": "drag the outlet's line: the fluid leaves towards the drag's right",
             "sink": "drag the sink's rectangle, corner to corner",
             "damping zone": "drag from where the zone begins to where it is at full "
                             "strength"}

    def __init__(self, sim: Simulation, renderer: Renderer):
        self.sim = sim
        self.renderer = renderer
        self.start: tuple[float, float] | None = None  # a drag's start (world, m)
        self.emitter: int | None = None  # the scene's emitter pouring now (E)
        self.tool = "wall"

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

    def arm(self, tool: str) -> str:
        """Make the next left-drag place a ``tool`` (again: walls); returns the hint."""
        self.tool = "wall" if tool == self.tool else tool
        return self.HINTS[self.tool]

    def begin_drag(self, px: float, py: float) -> None:
        self.start = self.snap(px, py) if self.tool == "wall" else self.world(px, py)

    def end_drag(self, px: float, py: float) -> str:
        """Finish the drag: a wall, or what the armed tool places (then walls again).
        Returns what happened, for the status line ("" for a click)."""
        if self.start is None:
            return ""
        tool = self.tool
        a = self.start
        b = self.snap(px, py) if tool == "wall" else self.world(px, py)
        self.start = None
        sa = np.array(self.renderer.camera.to_screen(np.asarray(a)))
        sb = np.array(self.renderer.camera.to_screen(np.asarray(b)))
        if np.hypot(*(sa - sb)) < 4:  # a click, not a drag
            return ""
        try:
            if tool == "wall":
                self.sim.add_wall(a, b)
                return f"wall added ({len(self.sim.scene.walls)} walls)"
            self.place(tool, a, b)
        except ValueError as e:  # SceneError is one
            return f"{tool} not added: {str(e).splitlines()[-1].strip()}"
        self.tool = "wall"
        return f"{tool} added (Ctrl+S saves it)"

    def place(self, tool: str, a, b) -> None:
        """Add a ``tool`` dragged from a to b (world, m) to the scene and the run."""
        sim, scene = self.sim, self.sim.scene
        if tool == "sink":
            lo, hi = tuple(np.minimum(a, b).tolist()), tuple(np.maximum(a, b).tolist())
            sim.set_flows(sinks=[*scene.sinks, Region("rectangle", (lo, hi))])
        elif tool == "damping zone":
            sim.set_flows(damping_zones=[*scene.damping_zones, DampingZone(a, b)])
        else:  # a line from a to b, the flow towards its right
            d = np.subtract(b, a)
            at = tuple((0.5 * np.add(a, b)).tolist())
            direction = (float(d[1]), float(-d[0]))
            width = float(np.hypot(*d))
            if tool == "inlet":
                inlet = Emitter(at=at, direction=direction, width=width,
                                speed=self.INFLOW_SPEED, name=f"inlet {len(scene.inlets) + 1}")
                sim.set_flows(inlets=[*scene.inlets, inlet])
            else:
                outlet = Outlet(at, direction, width, f"outlet {len(scene.outlets) + 1}")
                sim.set_flows(outlets=[*scene.outlets, outlet])

    def wall_at(self, px: float, py: float) -> int | None:
        """The wall segment under the cursor, where it is now (moving walls move)."""
        seg = self.sim.walls
        if not len(seg):
            return None
        sx, sy = self.renderer.camera.to_screen(seg)
        a = np.stack([sx[:, 0], sy[:, 0]], axis=1)
        b = np.stack([sx[:, 1], sy[:, 1]], axis=1)
        ab = b - a
        t = np.clip(((np.array([px, py]) - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-12),
                    0.0, 1.0)
        d = np.hypot(*(a + t[:, None] * ab - [px, py]).T)
        i = int(np.argmin(d))
        return i if d[i] <= self.PICK_PX else None

    def toggle_motion(self, px: float, py: float) -> str:
        """The wall under the cursor oscillates along its normal from now on (a
        paddle: a spacing either way, PADDLE_PERIOD, ramped up over the first
        period); again: it stops where it is. Returns what happened."""
        i = self.wall_at(px, py)
        if i is None:
            return ""
        sim = self.sim
        try:
            if sim.scene.wall_motions and sim.scene.wall_motions[i] is not None:
                sim.set_wall_motion(i, None)
                return "the wall stopped where it is"
            a, b = sim.walls[i]
            d = b - a
            normal = np.array([-d[1], d[0]]) / np.hypot(*d)
            period, t0 = self.PADDLE_PERIOD, sim.time
            t = np.arange(0.0, self.PADDLE_PERIODS * period + 1e-9, period / 40)
            s = sim.scene.spacing * np.minimum(t / period, 1.0) * np.sin(2 * np.pi * t / period)
            rows = tuple((float(t0 + tk), float(sk * normal[0]), float(sk * normal[1]))
                         for tk, sk in zip(t, s))
            sim.set_wall_motion(i, WallMotion(translation=rows, about=tuple(map(float, a))))
        except ValueError as e:  # SceneError is one
            return f"the wall cannot move so: {str(e).splitlines()[-1].strip()}"
        return (f"the wall moves {sim.scene.spacing:g} m either way along its normal, "
                f"period {self.PADDLE_PERIOD:g} s (Ctrl+S saves it)")

    def delete_at(self, px: float, py: float) -> str:
        """Delete the wall under the cursor, else the sink it is in, the inlet or
        outlet line or the damping zone's first line under it. Returns what
        happened ("" for nothing)."""
        sim, scene, cam = self.sim, self.sim.scene, self.renderer.camera
        i = self.wall_at(px, py)
        if i is not None:
            sim.remove_wall(i)
            return f"wall deleted ({len(sim.scene.walls)} walls)"
        x, y = self.world(px, py)
        for k, r in enumerate(scene.sinks):
            if r.contains(np.array([x]), np.array([y]), 0.0)[0]:
                sim.set_flows(sinks=[s for j, s in enumerate(scene.sinks) if j != k])
                return "sink deleted"

        def near(a, b) -> bool:  # the cursor within PICK_PX of the segment a-b
            sa, sb = (np.array(cam.to_screen(np.asarray(p, float))) for p in (a, b))
            ab = sb - sa
            t = np.clip((np.array([px, py]) - sa) @ ab / max(ab @ ab, 1e-12), 0.0, 1.0)
            return bool(np.hypot(*(sa + t * ab - [px, py])) <= self.PICK_PX)

        for key in ("inlets", "outlets"):
            items = getattr(scene, key)
            for k, e in enumerate(items):
                u = e.unit()
                half = 0.5 * (e.width or scene.spacing) * np.array([-u[1], u[0]])
                if near(np.subtract(e.at, half), np.add(e.at, half)):
                    sim.set_flows(**{key: [o for j, o in enumerate(items) if j != k]})
                    return f"{key[:-1]} deleted"
        for k, z in enumerate(scene.damping_zones):
            ring = z.region(scene.domain_min, scene.domain_max)
            axis = np.subtract(z.end, z.start)
            on_line = np.abs((ring - z.start) @ axis) <= 1e-9 * (axis @ axis)
            ends = ring[on_line]
            if len(ends) >= 2 and near(ends[0], ends[-1]):
                sim.set_flows(damping_zones=[o for j, o in enumerate(scene.damping_zones)
                                             if j != k])
                return "damping zone deleted"
        return ""

    def toggle_emitter(self, px: float, py: float) -> str:
        """Start pouring at the cursor: an emitter in the scene from now on, straight
        down, three spacings wide; again: it stops now. Ctrl+S saves it with the
        scene. Returns what happened, for the status line."""
        sim = self.sim
        if self.emitter is not None:
            emitters = list(sim.scene.emitters)
            k, self.emitter = self.emitter, None
            if sim.time > emitters[k].start:
                emitters[k] = dataclasses.replace(emitters[k], stop=sim.time)
            else:  # stopped before it began (paused): no emitter at all
                del emitters[k]
            sim.set_emitters(emitters)
            return "pouring stopped"
        e = Emitter(at=self.world(px, py), width=3 * sim.scene.spacing, speed=self.EMIT_SPEED,
                    start=sim.time, name=f"pour {len(sim.scene.emitters) + 1}")
        try:
            sim.add_emitter(e)
        except SceneError as err:
            return f"cannot pour there: {str(err).splitlines()[-1].strip()}"
        self.emitter = len(sim.scene.emitters) - 1
        return "pouring"

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
            editor.begin_drag(*event.pos)
        elif event.type == pg.MOUSEBUTTONUP and event.button == 1:
            self.message = editor.end_drag(*event.pos) or self.message
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
            self.message = editor.delete_at(*self.cursor) or self.message
        elif key == pg.K_m:
            self.message = editor.toggle_motion(*self.cursor) or self.message
        elif key in (pg.K_i, pg.K_o, pg.K_k, pg.K_b):
            tool = {pg.K_i: "inlet", pg.K_o: "outlet", pg.K_k: "sink",
                    pg.K_b: "damping zone"}[key]
            self.message = editor.arm(tool)
        elif key == pg.K_e:
            self.message = editor.toggle_emitter(*self.cursor)
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
        if editor.start is not None:  # what is being dragged
            a = np.array(camera.to_screen(np.asarray(editor.start)), float)
            b = np.array(self.cursor, float)
            colour = {"wall": (255, 210, 90), "sink": SINK, "damping zone": DAMPING}.get(
                editor.tool, EMITTER)
            if editor.tool == "sink":
                pg.draw.polygon(screen, colour, [a, (b[0], a[1]), b, (a[0], b[1])], 1)
            else:
                pg.draw.line(screen, colour, a, b, 2)
            if editor.tool in ("inlet", "outlet"):  # the flow's side: the drag's right
                d = b - a
                mid = 0.5 * (a + b)
                normal = np.array([-d[1], d[0]]) / max(np.hypot(*d), 1e-9)
                pg.draw.line(screen, colour, mid, mid + 20 * normal, 2)
        font = self.renderer.font
        screen.blit(font.render(self.status(fps), True, TEXT), (8, 5))
        wx, wy = camera.to_world(*self.cursor)
        footer = (f"{MODE_LABELS[self.renderer.mode]}   draw {self.draw_ms:.1f} ms   cursor "
                  f"({wx:.3f}, {wy:.3f}) m   left-drag: {editor.tool}   H: help")
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
                + (f" ({st['solve_density_iterations']}+{st['solve_divergence_iterations']} "
                   "iterations)" if sim.scene.method == "dfsph" else "")
                + f"  {self.n_steps} steps/frame"
                + ("  PAUSED" if self.paused else ""))


VIDEO_INSTALL = 'pip install "sphfluid[video]"  (or: pip install imageio-ffmpeg)'


METADATA_KEY = "sphfluid_metadata"  # the PNG text chunk holding the run metadata


class PngFrames:
    """frame_NNNNN.png in a folder, each written atomically (Pillow), with the
    run metadata as a text chunk."""

    def __init__(self, folder: Path, size: tuple[int, int], fps: float, metadata: str):
        from PIL import Image, PngImagePlugin

        self.image, self.size = Image, size
        self.info = PngImagePlugin.PngInfo()
        self.info.add_text(METADATA_KEY, metadata)
        self.folder = folder
        folder.mkdir(parents=True, exist_ok=True)
        self.count = 0

    def add(self, pygame, surface) -> None:
        from .output import replacing

        rgb = self.image.frombytes("RGB", self.size, pygame.image.tostring(surface, "RGB"))
        with replacing(self.folder / f"frame_{self.count:05d}.png") as tmp:
            rgb.save(tmp, format="PNG", pnginfo=self.info)
        self.count += 1

    def close(self) -> None:
        pass

    def abort(self) -> None:
        pass


class _MovieFile:
    """A GIF or MP4 written under a temporary name, renamed into place by close()."""

    def __init__(self, path: Path):
        from .output import replacing

        self.path = path
        self._replacing = replacing(path)
        self.tmp = self._replacing.__enter__()

    def _finish(self, error: BaseException | None) -> None:
        if error is None:
            self._replacing.__exit__(None, None, None)
        else:
            self._replacing.__exit__(type(error), error, error.__traceback__)


class GifFrames(_MovieFile):
    """An animated GIF (Pillow): each frame reduced to a palette as it comes;
    the run metadata as its comment."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: str):
        from PIL import Image

        super().__init__(path)
        self.image, self.size, self.fps = Image, size, fps
        self.comment = metadata.encode("utf-8")
        self.frames: list = []

    def add(self, pygame, surface) -> None:
        rgb = self.image.frombytes("RGB", self.size, pygame.image.tostring(surface, "RGB"))
        self.frames.append(rgb.quantize(colors=256, method=self.image.Quantize.MEDIANCUT))

    def close(self) -> None:
        self.frames[0].save(self.tmp, format="GIF", save_all=True,
                            append_images=self.frames[1:], duration=round(1000 / self.fps),
                            loop=0, comment=self.comment)
        self._finish(None)

    def abort(self) -> None:
        self._finish(RuntimeError("aborted"))


class Mp4Frames(_MovieFile):
    """An H.264 MP4 by the ffmpeg that imageio-ffmpeg ships, frames streamed to it;
    the run metadata as its comment."""

    def __init__(self, path: Path, size: tuple[int, int], fps: float, metadata: str):
        import imageio_ffmpeg

        super().__init__(path)
        # yuv420p (what players expect) needs even sides: pad an odd one by a pixel
        self.writer = imageio_ffmpeg.write_frames(
            str(self.tmp), size, fps=fps, codec="libx264", quality=7, macro_block_size=1,
            output_params=["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-metadata",
                           f"comment={metadata}", "-f", "mp4"])
        self.writer.send(None)  # start ffmpeg

    def add(self, pygame, surface) -> None:
        self.writer.send(pygame.image.tostring(surface, "RGB"))

    def close(self) -> None:
        self.writer.close()
        self._finish(None)

    def abort(self) -> None:
        try:
            self.writer.close()
        finally:
            self._finish(RuntimeError("aborted"))


def frame_sink(out: Path, size: tuple[int, int], fps: float, metadata: str = "{}"):
    """The writer record() renders into: PNGs in a folder, a .gif or an .mp4, each
    carrying metadata (the run metadata's JSON)."""
    suffix = out.suffix.lower()
    if suffix == ".gif":
        try:
            import PIL  # noqa: F401
        except ImportError:
            raise ValueError("writing a GIF needs Pillow (pip install pillow); "
                             "or give a folder to write PNG frames") from None
        return GifFrames(out, size, fps, metadata)
    if suffix == ".mp4":
        try:
            import imageio_ffmpeg  # noqa: F401
        except ImportError:
            raise ValueError(f"writing an MP4 needs imageio-ffmpeg: {VIDEO_INSTALL}; or write "
                             "a .gif, or a folder of PNG frames") from None
        return Mp4Frames(out, size, fps, metadata)
    if suffix:
        raise ValueError(f"--out: expected a folder for PNG frames, a .gif or an .mp4 file, "
                         f"got {out}")
    return PngFrames(out, size, fps, metadata)


def record(scene_path: str | Path, out: Path, *, duration: float | None = None,
           fps: float = 30.0, mode: str = "speed", size: tuple[int, int] = (800, 600),
           threads: int | None = None, progress=None) -> int:
    """Render frames headless: a folder of PNGs, an animated GIF, or an MP4 video
    (needs imageio-ffmpeg: the ``video`` extra), playing at fps frames per
    simulated second. A GIF or MP4 appears whole, at the end, or not at all.

    Returns the number of frames written.
    """
    import os

    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
    import pygame

    out = Path(out)
    scene = load_scene(scene_path)
    duration = duration if duration is not None else scene.duration
    if duration is None:
        raise ValueError("no duration given and the scene has no 'duration'")
    sim = Simulation(scene, threads=threads)
    from .metadata import run_metadata

    metadata = json.dumps(run_metadata(sim), sort_keys=True)
    pygame.display.init()
    pygame.font.init()
    try:
        sink = frame_sink(out, size, fps, metadata)
        surface = pygame.Surface(size)
        renderer = Renderer(sim, size, mode)
        n_frames = int(duration * fps + 1e-9) + 1
        try:
            for k in range(n_frames):
                sim.advance_to(k / fps)
                surface.fill(BACKGROUND)
                renderer.draw(surface)
                label = renderer.font.render(f"t = {sim.time:.3f} s", True, TEXT)
                surface.blit(label, (8, 5))
                sink.add(pygame, surface)
                if progress:
                    progress(k + 1, n_frames, sim)
        except BaseException:
            sink.abort()
            raise
        sink.close()
    finally:
        pygame.quit()
    return n_frames
