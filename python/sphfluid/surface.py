"""The liquid's surface: a smooth outline of the particles, as polylines.

The outline is the level MIN_KERNEL_SUM (0.5) of the colour field

    c(x) = sum_j V_j W(|x - x_j|, h),   V_j = m / rho0,

the probes' kernel sum (Wendland C2 with the run's support h; see
``sphfluid.probes``) with each particle's volume at rest: about 1 inside the
liquid, 0 in air, and 0.5 on a flat free surface half a spacing above the last
row of particles, which is where the fluid a lattice of spacing dx stands for
ends. (The volumes m / rho_j the probes use would put it 0.13 dx higher in the
seed, whose summed density falls by a fifth in the surface row.) c is sampled on a grid (by
default half a spacing apart) by adding each particle's kernel to the grid
nodes within its reach, and contoured by marching squares with ``contourpy``
(matplotlib's contouring engine, numpy its only dependency), which joins the
crossings into closed polylines, or into filled polygons with their holes.

``lines(sim)`` gives the outline as closed polylines, ``polygons(sim)`` the
liquid as (outline, holes) polygons; ``write_svg`` draws one frame as an SVG
file. ``sphfluid run --surface`` writes them per frame (docs/output.md).
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .probes import MIN_KERNEL_SUM, wendland

# Grid nodes times particles per block of the scatter: bounds its memory (~100 MB).
_BLOCK = 4_000_000


@dataclass(frozen=True)
class Grid:
    """A field sampled at the nodes (xs[i], ys[j]): values[i, j]."""

    xs: np.ndarray
    ys: np.ndarray
    values: np.ndarray


def colour_field(positions, volumes, support: float, cell: float) -> Grid:
    """c(x) = sum_j V_j W(|x - x_j|, support) at the nodes of a grid of the given
    cell size covering the particles and their kernels' reach (so c is 0 on the
    grid's border and every outline closes)."""
    pos = np.asarray(positions, dtype=np.float64).reshape(-1, 2)
    vol = np.broadcast_to(np.asarray(volumes, dtype=np.float64), (len(pos),))
    if not (support > 0 and cell > 0):
        raise ValueError(f"support and cell must be > 0, got {support!r} and {cell!r}")
    if len(pos) == 0:
        return Grid(np.zeros(2), np.zeros(2), np.zeros((2, 2)))
    reach = int(math.ceil(support / cell))
    lo = pos.min(0) - (reach + 1) * cell
    n = np.floor((pos.max(0) - lo) / cell).astype(np.int64) + reach + 3
    nx, ny = int(n[0]), int(n[1])
    base = np.floor((pos - lo) / cell).astype(np.int64)  # the node below-left of each
    span = np.arange(-reach, reach + 2)
    offsets = (span[:, None] * ny + span[None, :]).ravel()  # flat, i major
    total = np.zeros(nx * ny)
    step = max(1, _BLOCK // len(offsets))
    for a in range(0, len(pos), step):
        b = slice(a, a + step)
        # squared distances from each particle to the nodes of its stencil, by axis
        ddx = (lo[0] + (base[b, 0, None] + span) * cell - pos[b, 0, None]) ** 2
        ddy = (lo[1] + (base[b, 1, None] + span) * cell - pos[b, 1, None]) ** 2
        w = wendland(np.sqrt(ddx[:, :, None] + ddy[:, None, :]), support) * vol[b, None, None]
        index = (base[b, 0] * ny + base[b, 1])[:, None] + offsets
        total += np.bincount(index.ravel(), weights=w.ravel(), minlength=nx * ny)
    return Grid(lo[0] + cell * np.arange(nx), lo[1] + cell * np.arange(ny),
                total.reshape(nx, ny))


def _default_cell(sim) -> float:
    return 0.5 * sim.scene.spacing


def sim_field(sim, cell: float | None = None) -> Grid:
    """The colour field of a simulation's particles (volumes m / rho0, its support)."""
    return colour_field(sim.positions, sim.particle_mass / sim.scene.rest_density,
                        sim.smoothing_length, cell or _default_cell(sim))


def _generator(grid: Grid, **kwargs):
    import contourpy

    return contourpy.contour_generator(grid.xs, grid.ys, grid.values.T, **kwargs)


def contour_lines(grid: Grid, level: float = MIN_KERNEL_SUM) -> list[np.ndarray]:
    """The level's crossings joined into polylines ((k, 2) arrays; a closed one
    ends at its first point)."""
    from contourpy import LineType

    return [np.asarray(line) for line in
            _generator(grid, line_type=LineType.Separate).lines(level)]


def contour_polygons(grid: Grid, level: float = MIN_KERNEL_SUM, min_hole: float = 0.0
                     ) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """The region c >= level as polygons: (outline, [holes]), each a closed (k, 2)
    array; largest outline first. Holes of area below min_hole are left out."""
    from contourpy import FillType

    points, offsets = _generator(grid, fill_type=FillType.OuterOffset).filled(level, np.inf)
    out = []
    for pts, offs in zip(points, offsets):
        rings = [np.asarray(pts[a:b]) for a, b in zip(offs[:-1], offs[1:])]
        out.append((rings[0], [r for r in rings[1:] if abs(area(r)) >= min_hole]))
    out.sort(key=lambda poly: -abs(area(poly[0])))
    return out


def area(ring: np.ndarray) -> float:
    """The signed area of a closed ring (shoelace; positive anticlockwise)."""
    x, y = np.asarray(ring, dtype=np.float64).T
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def lines(sim, cell: float | None = None) -> list[np.ndarray]:
    """The liquid's outline in a simulation: closed polylines, m."""
    return contour_lines(sim_field(sim, cell))


def polygons(sim, cell: float | None = None) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    """The liquid in a simulation as (outline, holes) polygons, largest first;
    holes smaller than a particle (a spacing squared) are left out: a void
    between a few particles is the lattice's noise, not air."""
    return sim_polygons(sim, sim_field(sim, cell))


def sim_polygons(sim, grid: Grid) -> list[tuple[np.ndarray, list[np.ndarray]]]:
    return contour_polygons(grid, min_hole=sim.scene.spacing**2)


# --------------------------------------------------------------------------- SVG

def svg_text(polys, walls, lo, hi, *, time: float | None = None,
             metadata: dict[str, Any] | None = None, width_px: int = 800) -> str:
    """One frame as SVG: the domain lo..hi (m) with y up, the liquid filled (rings
    by the even-odd rule, so holes stay empty), the walls as lines, and the
    metadata as JSON in the <metadata> element. Coordinates are in metres."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    size = hi - lo
    height_px = max(1, round(width_px * size[1] / size[0]))
    stroke = 0.004 * float(max(size))

    def ring_path(ring):
        xy = " L ".join(f"{x:.6g} {y:.6g}" for x, y in ring)
        return f"M {xy} Z"

    liquid = " ".join(ring_path(r) for outline, holes in polys for r in (outline, *holes))
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<svg xmlns="http://www.w3.org/2000/svg" width="{width_px}" height="{height_px}" '
           f'viewBox="{lo[0]:.6g} {-hi[1]:.6g} {size[0]:.6g} {size[1]:.6g}">']
    if metadata is not None:
        text = json.dumps(metadata, sort_keys=True).replace("&", "&amp;").replace("<", "&lt;")
        out.append(f"  <metadata>{text}</metadata>")
    if time is not None:
        out.append(f"  <title>t = {time:.6g} s</title>")
    out.append('  <g transform="scale(1,-1)">')
    out.append(f'    <rect x="{lo[0]:.6g}" y="{lo[1]:.6g}" width="{size[0]:.6g}" '
               f'height="{size[1]:.6g}" fill="#10141c"/>')
    if liquid:
        out.append(f'    <path d="{liquid}" fill="#3c8ce6" fill-rule="evenodd" '
                   f'stroke="#a0d2ff" stroke-width="{stroke / 2:.4g}"/>')
    for a, b in np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2):
        out.append(f'    <line x1="{a[0]:.6g}" y1="{a[1]:.6g}" x2="{b[0]:.6g}" '
                   f'y2="{b[1]:.6g}" stroke="#dcdcdc" stroke-width="{stroke:.4g}" '
                   'stroke-linecap="round"/>')
    out += ["  </g>", "</svg>", ""]
    return "\n".join(out)


def write_svg(path: Path, sim, metadata: dict[str, Any] | None = None, polys=None) -> Path:
    """The simulation's liquid (its ``polygons``, unless given) and walls now as
    an SVG file, written atomically."""
    from .output import replacing

    if polys is None:
        polys = polygons(sim)
    text = svg_text(polys, sim.walls, sim.scene.domain_min, sim.scene.domain_max,
                    time=sim.time, metadata=metadata)
    with replacing(Path(path)) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)
