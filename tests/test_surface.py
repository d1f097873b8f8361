"""The liquid's outline (sphfluid.surface): contours, SVG and VTK export."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from conftest import ROOT
from sphfluid import Simulation, load_scene, output
from sphfluid import surface as sf
from sphfluid.probes import MIN_KERNEL_SUM

SVG = "{http://www.w3.org/2000/svg}"


def lattice_disc(radius: float, dx: float, shift: float = 0.0) -> np.ndarray:
    """The square lattice's points (offset by shift spacings) inside a circle."""
    n = int(np.ceil(radius / dx)) + 2
    g = (np.arange(-n, n) + 0.5 + shift) * dx
    x, y = np.meshgrid(g, g)
    pts = np.column_stack([x.ravel(), y.ravel()])
    return pts[np.hypot(*pts.T) < radius]


@pytest.mark.parametrize("shift", [0.0, 0.37])
@pytest.mark.parametrize("support", [2.0, 3.0])
def test_the_outline_of_a_disc_of_particles_is_its_circle(shift, support):
    """A disc of radius R filled on the lattice (each particle a dx^2 of fluid):
    its outline is one closed line, the circle to within the lattice's steps.
    Contoured at 0.4 instead of 0.5 the mean radius is 0.2 dx too large."""
    dx, radius = 0.02, 0.5
    pts = lattice_disc(radius, dx, shift)
    grid = sf.colour_field(pts, dx * dx, support * dx, 0.5 * dx)
    lines = sf.contour_lines(grid)
    assert len(lines) == 1 and np.array_equal(lines[0][0], lines[0][-1])  # closed
    r = np.hypot(*lines[0].T)
    assert abs(r.mean() - radius) < 0.1 * dx
    assert np.abs(r - radius).max() < 0.5 * dx
    # the enclosed area is the particles' N dx^2
    assert abs(sf.area(lines[0])) == pytest.approx(len(pts) * dx * dx, rel=0.01)
    # the field is the kernel sum of the particles at the nodes
    i, j = len(grid.xs) // 2 + 3, len(grid.ys) // 2 - 5
    r_node = np.hypot(grid.xs[i] - pts[:, 0], grid.ys[j] - pts[:, 1])
    from sphfluid.probes import wendland

    assert grid.values[i, j] == pytest.approx((wendland(r_node, support * dx) * dx * dx).sum())


def test_a_ring_is_one_polygon_with_one_hole_and_its_svg_leaves_the_hole_empty():
    dx = 0.02
    ring = lattice_disc(0.5, dx)
    ring = ring[np.hypot(*ring.T) > 0.25]
    grid = sf.colour_field(ring, dx * dx, 3 * dx, 0.5 * dx)
    polys = sf.contour_polygons(grid)
    assert len(polys) == 1
    outline, holes = polys[0]
    assert len(holes) == 1
    assert abs(sf.area(outline)) == pytest.approx(np.pi * 0.5**2, rel=0.02)
    assert abs(sf.area(holes[0])) == pytest.approx(np.pi * 0.25**2, rel=0.05)
    assert not sf.contour_polygons(grid, min_hole=0.25)[0][1]  # smaller than min_hole: gone
    text = sf.svg_text(polys, [[[-1, -1], [1, -1]]], (-1, -1), (1, 1), time=0.5,
                       metadata={"a": "<b>"})
    root = ET.fromstring(text)
    path = root.find(f"{SVG}g/{SVG}path")
    assert path.get("fill-rule") == "evenodd" and path.get("d").count("M") == 2
    assert len(root.findall(f"{SVG}g/{SVG}line")) == 1
    assert root.find(f"{SVG}metadata").text == '{"a": "<b>"}'


def test_no_particles_no_outline():
    grid = sf.colour_field(np.zeros((0, 2)), 1.0, 0.1, 0.05)
    assert sf.contour_lines(grid) == [] and sf.contour_polygons(grid) == []


def test_bad_sizes_are_refused():
    with pytest.raises(ValueError, match="must be > 0"):
        sf.colour_field(np.zeros((3, 2)), 1.0, 0.0, 0.05)


@pytest.mark.parametrize("name", ["hydrostatic.json", "water/hydrostatic.json"])
def test_the_outline_of_a_tank_at_rest_is_its_water_level(name):
    """The bundled hydrostatic tanks (1 m of water, seed and wcsph): the top edge
    of the outline is at the water's level, half a spacing above its highest
    particle (the fill height, but for wcsph's compressed start, W23b: 2.3 mm
    below it)."""
    scene = load_scene(ROOT / "scenes" / name)
    sim = Simulation(scene, threads=1)
    polys = sf.polygons(sim)
    assert len(polys) == 1 and not polys[0][1]
    outline = polys[0][0]
    (x0, _), (x1, y1) = scene.regions[0].bounds()
    middle = outline[(outline[:, 0] > x0 + 0.2) & (outline[:, 0] < x1 - 0.2)]
    top = middle[middle[:, 1] > 0.5 * y1][:, 1]
    level = sim.positions[:, 1].max() + 0.5 * scene.spacing
    assert level == pytest.approx(y1, abs=0.003)
    assert np.abs(top - level).max() < 0.05 * scene.spacing
    assert sf.sim_field(sim).values.max() == pytest.approx(2 * MIN_KERNEL_SUM, abs=0.03)


@pytest.fixture(scope="module")
def surface_run(tmp_path_factory):
    from sphfluid.cli import main

    out = tmp_path_factory.mktemp("surface_run") / "out"
    assert main(["run", str(ROOT / "scenes" / "hydrostatic.json"), "--duration", "0.02",
                 "--every", "0.01", "--threads", "1", "--out", str(out), "--format", "vtk",
                 "--surface", "--quiet"]) == 0
    return out


def test_run_surface_writes_an_outline_per_frame_in_vtk_and_svg(surface_run):
    parts = [(t, part, name, file) for t, part, name, file in pvd_datasets(surface_run)
             if part == "2"]
    assert [p[3] for p in parts] == [f"surface_{k:05d}.vtu" for k in range(3)]
    assert all(name == "surface" for _, _, name, _ in parts)
    meta = output.read_metadata(surface_run / "frame_00000.vtu")
    for k in range(3):
        d = output.read_vtu(surface_run / f"surface_{k:05d}.vtu")
        assert set(d["types"]) == {4}  # VTK_POLY_LINE
        line = d["points"][:, :2]
        assert np.array_equal(line[0], line[-1]) and len(line) > 50  # one closed outline
        assert output.read_metadata(surface_run / f"surface_{k:05d}.vtu") == meta
        svg = ET.parse(surface_run / f"surface_{k:05d}.svg").getroot()
        assert svg.find(f"{SVG}metadata").text is not None
        assert svg.find(f"{SVG}g/{SVG}path").get("d").count("M") == 1


def test_surface_needs_out(capsys):
    from sphfluid.cli import main

    assert main(["run", str(ROOT / "scenes" / "hydrostatic.json"), "--duration", "0.01",
                 "--surface", "--quiet"]) == 2
    assert "--surface needs --out" in capsys.readouterr().err


def pvd_datasets(folder):
    root = ET.parse(folder / output.PVD_NAME).getroot()
    return [(float(d.get("timestep")), d.get("part"), d.get("name"), d.get("file"))
            for d in root.iter("DataSet")]
