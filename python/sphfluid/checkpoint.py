"""Checkpoints: everything a run's next step depends on, in one .npz file.

A checkpoint holds every particle field of the solver in storage order (the
state, the last evaluation's densities, pressures and accelerations, and each
method's own fields: wcsph's kernel sums, its shift and shifting sums), the
clock (time, step count, the last time step and its limit), the counts
(particles removed, steps retried), the blow-up guard's energy budget and the
energy carried out of the domain, and the method's own numbers. A run resumed
from it with the same sphfluid continues bit for bit as the run that wrote it
would have, on any thread count.

The file: ``positions``, ``velocities``, ``accelerations``, ``densities``,
``pressures``, ``ids``, ``time`` and ``step_count`` under those names (what
``np.load`` shows a reader), the method's fields as ``field_<name>``, and
``checkpoint``: a JSON string with the format, the run's metadata
(``sphfluid.metadata.run_metadata``), the scene (``Scene.to_dict()``) and the
solver's numbers. Written under a temporary name and renamed into place.
"""
from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from . import _core
from .metadata import run_metadata, scene_hash
from .output import replacing

FORMAT = "sphfluid-checkpoint/1"
META_KEY = "checkpoint"
# the core's field names -> the keys a reader of the file sees
READABLE = {"position": "positions", "velocity": "velocities", "acceleration": "accelerations",
            "density": "densities", "pressure": "pressures", "id": "ids"}
_FIELD_PREFIX = "field_"


class CheckpointError(ValueError):
    """A file that is not a checkpoint, or one this run cannot continue from
    (another sphfluid version, another scene, another method's fields)."""


def save(sim, path) -> Path:
    """Write sim's checkpoint to path (atomically); returns the path."""
    path = Path(path)
    snap = sim._solver.snapshot()
    fields = snap.pop("fields")
    meta = {"format": FORMAT, **run_metadata(sim), "scene": sim.scene.to_dict(),
            "solver": snap, "fields": list(fields)}
    arrays = {READABLE.get(name, _FIELD_PREFIX + name): a for name, a in fields.items()}
    with replacing(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, **arrays, time=np.float64(snap["time"]),
                 step_count=np.int64(snap["step_count"]),
                 **{META_KEY: np.array(json.dumps(meta, sort_keys=True))})
    return path


def read(path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(metadata, fields by the core's names) of a checkpoint file, or
    CheckpointError saying why it is not one."""
    path = Path(path)
    try:
        with open(path, "rb") as fh, np.load(fh, allow_pickle=False) as z:
            if META_KEY not in z.files:
                raise CheckpointError(f"{path}: not a sphfluid checkpoint (no '{META_KEY}' "
                                      "entry; frames and other .npz files cannot be resumed)")
            meta = json.loads(str(z[META_KEY][()]))
            if not isinstance(meta, dict) or meta.get("format") != FORMAT:
                raise CheckpointError(f"{path}: not a {FORMAT} file "
                                      f"(format {meta.get('format')!r})" if isinstance(meta, dict)
                                      else f"{path}: not a sphfluid checkpoint")
            readable = {v: k for k, v in READABLE.items()}
            fields = {}
            for name in meta["fields"]:
                key = READABLE.get(name, _FIELD_PREFIX + name)
                if key not in z.files:
                    raise CheckpointError(f"{path}: the field '{name}' is missing")
                fields[readable.get(key, name)] = z[key]
    except CheckpointError:
        raise
    except (OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as e:
        raise CheckpointError(f"{path}: cannot be read as a checkpoint ({e})") from None
    return meta, fields


def check_version(meta: dict[str, Any], path) -> None:
    written = meta.get("sphfluid_version")
    if written != _core.__version__:
        raise CheckpointError(f"{path}: written by sphfluid {written}, this is "
                              f"{_core.__version__}: resume it with the version that wrote it")


def restore(sim, path) -> None:
    """Continue sim from the checkpoint at path: sim's scene must be the one the
    checkpoint was written for (CheckpointError otherwise, sim unchanged)."""
    meta, fields = read(path)
    _continue(sim, meta, fields, path)


def _continue(sim, meta: dict[str, Any], fields: dict[str, np.ndarray], path) -> None:
    check_version(meta, path)
    mine = scene_hash(sim.scene)
    if meta.get("scene_hash") != mine:
        name = meta.get("scene_name") or "unnamed"
        raise CheckpointError(
            f"{path}: written for another scene ('{name}', hash {str(meta.get('scene_hash'))[:12]}; "
            f"this one {mine[:12]}): run the scene it was written for, or "
            "Simulation.from_checkpoint(path), which takes the checkpoint's own scene")
    try:
        sim._solver.restore({**meta["solver"], "fields": fields})
    except (ValueError, KeyError, TypeError) as e:
        raise CheckpointError(f"{path}: {e}") from None


def load(path, threads: int | None = None):
    """A Simulation of the checkpoint's own scene, continued from it."""
    from .scene import SceneError, load_scene
    from .simulation import Simulation

    meta, fields = read(path)
    check_version(meta, path)
    try:
        scene = load_scene(meta["scene"])
    except (SceneError, KeyError) as e:
        raise CheckpointError(f"{path}: its scene does not load: {e}") from None
    sim = Simulation(scene, threads=threads)
    _continue(sim, meta, fields, path)
    return sim
