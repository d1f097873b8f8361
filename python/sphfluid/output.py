"""The frames of ``sphfluid run --out DIR``: .npz files, or VTK files for ParaView.

``--format npz`` (the default) writes ``frame_NNNNN.npz``: time, positions,
velocities, densities, pressures, ids, and ``metadata``, the run's metadata
(``sphfluid.metadata.run_metadata``) as a JSON string.

``--format vtk`` writes, with pyevtk:

- ``frame_NNNNN.vtu``: a VTK XML unstructured grid, one vertex cell per
  particle, the points at z = 0, and as point data ``velocities`` and
  ``accelerations`` (3 components, z = 0), ``densities``, ``pressures`` and
  ``ids``; as field data ``TimeValue`` (s) and ``sphfluid_metadata`` (a string
  holding the metadata's JSON);
- ``walls.vtu``: the wall segments joined into polylines where one ends at the
  next one's start, with the metadata as field data; written once, and again as
  ``walls_NNNNN.vtu`` from the frame at which they change;
- ``frames.pvd``: the collection ParaView opens as one animation: each frame's
  time, the particles as part 0 and the walls as part 1, and the metadata's JSON
  in an XML comment.

Every file is written under a temporary name in its folder (``.NAME.PID.tmp.EXT``)
and renamed into place, and frames.pvd is rewritten the same way after each
frame: a run stopped at any moment leaves whole files, and a collection that
lists only whole frames. ``read_vtu`` and ``read_metadata`` read them back.
"""
from __future__ import annotations

import contextlib
import json
import os
import threading
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Any, Iterator
from xml.sax.saxutils import quoteattr

import numpy as np

FORMATS = ("npz", "vtk")
PVD_NAME = "frames.pvd"
METADATA_FIELD = "sphfluid_metadata"  # the VTK files' field data array
PVD_COMMENT = "sphfluid-metadata"  # the .pvd's comment: "<!-- sphfluid-metadata {...} -->"
PYEVTK_INSTALL = 'pip install "pyevtk>=1.7"'
_VTK_VERTEX, _VTK_POLY_LINE = 1, 4  # VTK cell types


class WriterMissingError(RuntimeError):
    """The VTK writer (pyevtk) is not installed."""


def require_vtk_writer():
    """pyevtk's low-level module, or WriterMissingError saying how to install it."""
    try:
        from pyevtk import vtk
    except ImportError:
        raise WriterMissingError(
            f"--format vtk writes with pyevtk, which is not installed: {PYEVTK_INSTALL}"
        ) from None
    return vtk


_writing = 0  # replacing() blocks open
_held: BaseException | None = None  # a stop that came meanwhile


def raise_or_hold(stop: BaseException) -> None:
    """For a signal handler that stops the program (the command line's, on
    SIGTERM and Ctrl+C): raises `stop` now, or, while replacing() writes a
    file, as soon as it is whole. Raised inside a library's write, a stop can
    leave it broken: numpy's savez, stopped within zipfile's close, raised a
    ValueError of its own over it, and `sphfluid run` ended with a traceback
    instead of its message."""
    global _held
    if _writing:
        _held = _held or stop
    else:
        raise stop


@contextlib.contextmanager
def _stops_held() -> Iterator[None]:
    global _writing, _held
    if threading.current_thread() is not threading.main_thread():
        yield  # (signal handlers run in the main thread: its writes are held)
        return
    _writing += 1
    try:
        yield
    finally:
        _writing -= 1
        if not _writing and _held is not None:
            stop, _held = _held, None
            raise stop


@contextlib.contextmanager
def replacing(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (same folder and extension) to write to,
    renamed onto ``path`` when the block ends, removed if it raises; a stop
    that comes meanwhile waits until then (raise_or_hold)."""
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    with _stops_held():
        try:
            yield tmp
            os.replace(tmp, path)
        except BaseException:
            with contextlib.suppress(OSError):
                tmp.unlink()
            raise


def frame_writer(fmt: str, folder: Path, sim, surface: bool = False):
    """The writer of ``--format fmt`` frames into folder, with sim's run metadata;
    with surface, each frame's liquid outline too (sphfluid.surface)."""
    from .metadata import run_metadata

    if fmt not in FORMATS:
        raise ValueError(f"format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    writer = VtkFrames if fmt == "vtk" else NpzFrames
    return writer(folder, run_metadata(sim), surface=surface)


def write_surface_svg(folder: Path, count: int, sim, metadata: dict[str, Any],
                      polys=None) -> None:
    from .surface import write_svg

    write_svg(Path(folder) / f"surface_{count:05d}.svg", sim, metadata, polys)


class NpzFrames:
    """frame_NNNNN.npz, one per write(); with surface, surface_NNNNN.svg too."""

    def __init__(self, folder: Path, metadata: dict[str, Any], surface: bool = False):
        self.folder = Path(folder)
        self.metadata = metadata
        self.metadata_json = json.dumps(metadata, sort_keys=True)
        self.surface = surface
        self.count = 0

    def resume(self, count: int) -> None:
        """Go on from frame number count (a resumed run's next frame)."""
        self.count = count

    def write(self, sim) -> Path:
        path = self.folder / f"frame_{self.count:05d}.npz"
        with replacing(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, time=sim.time, positions=sim.positions, velocities=sim.velocities,
                     densities=sim.densities, pressures=sim.pressures, ids=sim.ids,
                     metadata=np.array(self.metadata_json))
        if self.surface:
            write_surface_svg(self.folder, self.count, sim, self.metadata)
        self.count += 1
        return path


class VtkFrames:
    """frame_NNNNN.vtu per write(), the walls whenever they change, and frames.pvd;
    with surface, the liquid's outline as surface_NNNNN.vtu (and .svg)."""

    def __init__(self, folder: Path, metadata: dict[str, Any], surface: bool = False):
        self.vtk = require_vtk_writer()
        self.folder = Path(folder)
        self.metadata = metadata
        # ASCII (VTK's string arrays are bytes) and sorted, so that files compare
        self.metadata_json = json.dumps(metadata, sort_keys=True, ensure_ascii=True)
        self.surface = surface
        self.count = 0
        # time, and the frame's particles, walls and surface files
        self.datasets: list[tuple[float, str, str | None, str | None]] = []
        self._walls: np.ndarray | None = None
        self._walls_file: str | None = None

    def resume(self, count: int) -> None:
        """Go on from frame number count (a resumed run's next frame): the
        collection keeps the frames before it that frames.pvd lists."""
        self.count = count
        pvd = self.folder / PVD_NAME
        if not pvd.exists():
            return
        parts: dict[str, dict[str, str]] = {"1": {}, "2": {}}  # walls, surface
        frames = []
        try:
            root = ET.parse(pvd).getroot()
        except ET.ParseError:  # (written atomically: not by a run of ours)
            return
        for d in root.iter("DataSet"):
            t, file = d.get("timestep"), d.get("file")
            if d.get("part") in parts:
                parts[d.get("part")][t] = file
            elif file.startswith("frame_") and int(file[6:11]) < count:
                frames.append((t, file))
        self.datasets = [(float(t), file, parts["1"].get(t), parts["2"].get(t))
                         for t, file in frames]

    def write(self, sim) -> Path:
        walls_file = self._write_walls(np.asarray(sim.walls, dtype=np.float64).reshape(-1, 2, 2))
        name = f"frame_{self.count:05d}.vtu"
        points = _xyz(sim.positions)
        n = len(points)
        cells = (np.arange(n, dtype=np.int64), np.arange(1, n + 1, dtype=np.int64),
                 np.full(n, _VTK_VERTEX, dtype=np.uint8))
        fields = {"velocities": _xyz(sim.velocities), "accelerations": _xyz(sim.accelerations),
                  "densities": np.array(sim.densities, dtype=np.float64),
                  "pressures": np.array(sim.pressures, dtype=np.float64),
                  "ids": np.array(sim.ids, dtype=np.int64)}
        write_vtu(self.folder / name, points, cells, point_data=fields,
                  field_data={"TimeValue": float(sim.time), METADATA_FIELD: self.metadata_json},
                  vtk=self.vtk)
        surface_file = self._write_surface(sim) if self.surface else None
        self.datasets.append((float(sim.time), name, walls_file, surface_file))
        with replacing(self.folder / PVD_NAME) as tmp:
            tmp.write_text(self.pvd_text(), encoding="ascii")
        self.count += 1
        return self.folder / name

    def _write_walls(self, walls: np.ndarray) -> str | None:
        """The walls' file for this frame, written when the walls differ from the last."""
        if self._walls is not None and np.array_equal(walls, self._walls):
            return self._walls_file
        self._walls = walls.copy()
        if len(walls) == 0:
            self._walls_file = None
            return None
        self._walls_file = "walls.vtu" if self.count == 0 else f"walls_{self.count:05d}.vtu"
        lines = wall_polylines(walls)
        points = _xyz(np.concatenate(lines))
        cells = (np.arange(len(points), dtype=np.int64),
                 np.cumsum([len(line) for line in lines]).astype(np.int64),
                 np.full(len(lines), _VTK_POLY_LINE, dtype=np.uint8))
        write_vtu(self.folder / self._walls_file, points, cells,
                  field_data={METADATA_FIELD: self.metadata_json}, vtk=self.vtk)
        return self._walls_file

    def _write_surface(self, sim) -> str:
        """The liquid's outline as polylines (and as SVG), this frame's part 2."""
        from .surface import contour_lines, sim_field, sim_polygons

        name = f"surface_{self.count:05d}.vtu"
        grid = sim_field(sim)
        outline = contour_lines(grid) or [np.zeros((0, 2))]
        points = _xyz(np.concatenate(outline))
        cells = (np.arange(len(points), dtype=np.int64),
                 np.cumsum([len(line) for line in outline]).astype(np.int64),
                 np.full(len(outline), _VTK_POLY_LINE, dtype=np.uint8))
        if len(points) == 0:
            cells = tuple(c[:0] for c in cells)
        write_vtu(self.folder / name, points, cells,
                  field_data={"TimeValue": float(sim.time), METADATA_FIELD: self.metadata_json},
                  vtk=self.vtk)
        write_surface_svg(self.folder, self.count, sim, self.metadata, sim_polygons(sim, grid))
        return name

    def pvd_text(self) -> str:
        """The collection of the frames written so far (times exact: repr)."""
        comment = self.metadata_json.replace("--", "-\\u002d")  # "--" may not occur in one
        lines = ['<?xml version="1.0"?>',
                 '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">',
                 f"  <!-- {PVD_COMMENT} {comment} -->",
                 "  <Collection>"]
        for t, frame, walls, surface in self.datasets:
            lines.append(f'    <DataSet timestep="{t!r}" part="0" name="particles" '
                         f"file={quoteattr(frame)}/>")
            if walls is not None:
                lines.append(f'    <DataSet timestep="{t!r}" part="1" name="walls" '
                             f"file={quoteattr(walls)}/>")
            if surface is not None:
                lines.append(f'    <DataSet timestep="{t!r}" part="2" name="surface" '
                             f"file={quoteattr(surface)}/>")
        lines += ["  </Collection>", "</VTKFile>", ""]
        return "\n".join(lines)


def wall_polylines(walls) -> list[np.ndarray]:
    """Segments (S, 2, 2) joined, in order, into polylines ((k, 2) arrays) wherever
    a segment starts exactly where the one before ends."""
    lines: list[list[np.ndarray]] = []
    for a, b in np.asarray(walls, dtype=np.float64).reshape(-1, 2, 2):
        if lines and np.array_equal(lines[-1][-1], a):
            lines[-1].append(b)
        else:
            lines.append([a, b])
    return [np.array(line) for line in lines]


def _xyz(a) -> np.ndarray:
    """(N, 2) -> (N, 3) float64 at z = 0: VTK's points and vectors have 3 components."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 2)
    out = np.zeros((len(a), 3))
    out[:, :2] = a
    return out


def write_vtu(path: Path, points: np.ndarray, cells: tuple[np.ndarray, np.ndarray, np.ndarray],
              point_data: dict[str, np.ndarray] | None = None,
              field_data: dict[str, float | str] | None = None, vtk=None) -> None:
    """A VTK XML unstructured grid, written atomically: points (N, 3), cells as
    (connectivity, offsets, types), point data arrays ((N,) or (N, 3)), and field
    data of numbers (Float64) and strings (String, ASCII). The arrays are appended
    raw, as VTK's own writers do; field data is inline, where ParaView reads it."""
    vtk = vtk or require_vtk_writer()
    point_data = point_data or {}
    arrays = [("Points", points)]
    arrays += list(zip(("connectivity", "offsets", "types"), cells))
    arrays += list(point_data.items())
    with replacing(path) as tmp:
        w = vtk.VtkFile(str(tmp)[: -len(tmp.suffix)], vtk.VtkUnstructuredGrid)
        try:
            w.openGrid()
            _field_data(w, field_data or {})
            w.openPiece(npoints=len(points), ncells=len(cells[2]))
            w.openElement("Points")
            _header(w, *arrays[0])
            w.closeElement("Points")
            w.openElement("Cells")
            for name, a in arrays[1:4]:
                _header(w, name, a)
            w.closeElement("Cells")
            if point_data:
                scalars = next((k for k, a in point_data.items() if a.ndim == 1), None)
                vectors = next((k for k, a in point_data.items() if a.ndim == 2), None)
                w.openData("Point", scalars=scalars, vectors=vectors)
                for name, a in point_data.items():
                    _header(w, name, a)
                w.closeData("Point")
            w.closePiece()
            w.closeGrid()
            for _, a in arrays:
                w.appendData(np.ascontiguousarray(a).ravel())
            w.save()
        finally:
            w.xml.stream.close()  # already closed by save(); not left open by an error


def _header(w, name: str, a: np.ndarray) -> None:
    w.addHeader(name, a.dtype.name, a.shape[0], a.shape[1] if a.ndim == 2 else 1)


def _field_data(w, fields: dict[str, float | str]) -> None:
    """<FieldData> of the grid, each array one tuple in ASCII: a number as Float64, a
    string as VTK writes a String array (its bytes as integers, then 0)."""
    if not fields:
        return
    w.openData("Field")
    for name, value in fields.items():
        if isinstance(value, str):
            kind, text = "String", " ".join(map(str, value.encode("ascii"))) + " 0"
        else:
            kind, text = "Float64", repr(float(value))
        w.xml.openElement("DataArray").addAttributes(type=kind, Name=name, NumberOfTuples=1,
                                                      format="ascii")
        w.xml.addText(text).closeElement("DataArray")
    w.closeData("Field")


# -- reading back

_VTK_DTYPES = {name: np.dtype(name.lower()) for name in (
    "Int8", "UInt8", "Int16", "UInt16", "Int32", "UInt32", "Int64", "UInt64",
    "Float32", "Float64")}


def read_vtu(path) -> dict[str, Any]:
    """A .vtu this module wrote (arrays appended raw or inline in ASCII, not
    compressed), as {"points", "connectivity", "offsets", "types": arrays,
    "point_data", "cell_data": {name: array}, "field_data": {name: array, or a
    list of str for a String array}}; vectors come back (N, 3)."""
    raw = Path(path).read_bytes()
    appended = b""
    start = raw.find(b"<AppendedData")
    if start >= 0:  # raw bytes: not XML; the offsets count from the byte after "_"
        first = raw.index(b"_", raw.index(b">", start)) + 1
        appended = raw[first:raw.rindex(b"</AppendedData>")]
        raw = raw[:start] + b"</VTKFile>"
    root = ET.fromstring(raw)
    if root.get("type") != "UnstructuredGrid" or root.get("compressor"):
        raise ValueError(f"{path}: not an uncompressed VTK unstructured grid")
    order = "<" if root.get("byte_order", "LittleEndian") == "LittleEndian" else ">"
    header = _VTK_DTYPES[root.get("header_type", "UInt32")].newbyteorder(order)

    def array(el: ET.Element):
        kind, fmt = el.get("type"), el.get("format")
        if kind == "String":
            if fmt != "ascii":
                raise ValueError(f"{path}: String array {el.get('Name')} not in ASCII")
            codes = bytes(int(c) for c in (el.text or "").split())
            return [s.decode("ascii") for s in codes.split(b"\0")[:-1]]
        dtype = _VTK_DTYPES[kind].newbyteorder(order)
        if fmt == "ascii":
            a = np.array((el.text or "").split(), dtype=dtype.newbyteorder("="))
        elif fmt == "appended":
            offset = int(el.get("offset"))
            nbytes = int(np.frombuffer(appended, header, 1, offset)[0])
            a = np.frombuffer(appended, dtype, nbytes // dtype.itemsize,
                              offset + header.itemsize).astype(dtype.newbyteorder("="))
        else:
            raise ValueError(f"{path}: array format {fmt!r} not read here")
        ncomp = int(el.get("NumberOfComponents", "1"))
        return a.reshape(-1, ncomp) if ncomp > 1 else a

    grid = root.find("UnstructuredGrid")
    piece = grid.find("Piece")
    out: dict[str, Any] = {"points": array(piece.find("Points/DataArray"))}
    for el in piece.findall("Cells/DataArray"):
        out[el.get("Name")] = array(el)
    for key, el in (("field_data", grid.find("FieldData")), ("point_data", piece.find("PointData")),
                    ("cell_data", piece.find("CellData"))):
        out[key] = {a.get("Name"): array(a) for a in (el if el is not None else [])}
    return out


def read_metadata(path) -> dict[str, Any]:
    """The run metadata stored in an output file: a frame (.vtu, .npz), the walls
    (.vtu) or the collection (.pvd)."""
    path = Path(path)
    if path.suffix == ".npz":
        with np.load(path) as frame:
            return json.loads(frame["metadata"].item())
    if path.suffix == ".vtu":
        return json.loads(read_vtu(path)["field_data"][METADATA_FIELD][0])
    if path.suffix == ".pvd":
        parser = ET.XMLParser(target=ET.TreeBuilder(insert_comments=True))
        for node in ET.fromstring(path.read_text(encoding="utf-8"), parser=parser).iter():
            text = (node.text or "").strip() if node.tag is ET.Comment else ""
            if text.startswith(PVD_COMMENT + " "):
                return json.loads(text[len(PVD_COMMENT) + 1:])
    raise ValueError(f"{path}: no sphfluid metadata found")
