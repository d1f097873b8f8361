"""What produced a result: the metadata stored in every output file.

``run_metadata(sim)`` describes a running Simulation (version, git commit,
build, method, threads, scene hash) as a JSON-ready dict; ``scene_hash(scene)``
is the SHA-256 of the scene's canonical JSON. Both are cheap after the first
call in a process (the git commit is looked up once).
"""
from __future__ import annotations

import functools
import hashlib
import json
import os
import re
import subprocess
from pathlib import Path
from typing import Any

from . import _core

# python/sphfluid/metadata.py -> the source tree's root, when this is a checkout
_SOURCE_ROOT = Path(__file__).resolve().parents[2]
_GIT_TIMEOUT = 5.0  # s; a git that hangs (a network file system, a lock) is not waited for


def scene_hash(scene) -> str:
    """SHA-256 (hex) of the scene's canonical JSON: ``scene.to_dict()`` with its
    keys sorted, no spaces, ASCII only. A dict is hashed as given, so the
    ``scene.json`` that ``sphfluid run --out`` writes, loaded with ``json.load``,
    hashes to the run's ``scene_hash``."""
    d = scene.to_dict() if hasattr(scene, "to_dict") else scene
    text = json.dumps(d, sort_keys=True, separators=(",", ":"), ensure_ascii=True)
    return hashlib.sha256(text.encode("ascii")).hexdigest()


def _git(*args: str) -> str | None:
    """The output of git in the source tree, or None: not a checkout, no git, an
    error, or no answer within the timeout."""
    if not ((_SOURCE_ROOT / ".git").exists() and (_SOURCE_ROOT / "pyproject.toml").is_file()):
        return None  # an installed package: whatever repository encloses it is not ours
    env = {k: v for k, v in os.environ.items() if not k.startswith("GIT_")}
    try:
        r = subprocess.run(["git", "-C", str(_SOURCE_ROOT), "--no-optional-locks", *args],
                           capture_output=True, text=True, timeout=_GIT_TIMEOUT,
                           stdin=subprocess.DEVNULL, env=env, check=False)
    except (OSError, subprocess.SubprocessError):
        return None
    return r.stdout if r.returncode == 0 else None


@functools.lru_cache(maxsize=1)
def git_state() -> tuple[str | None, bool | None]:
    """(commit, dirty) of the source tree this package was imported from, or
    (None, None) outside a checkout. dirty: tracked files differ from the commit."""
    out = _git("rev-parse", "--verify", "HEAD")
    commit = out.strip() if out else None
    if commit is None or not re.fullmatch(r"[0-9a-f]{40}|[0-9a-f]{64}", commit):
        return None, None
    status = _git("status", "--porcelain", "--untracked-files=no")
    return commit, (None if status is None else bool(status.strip()))


def source_line() -> str:
    """The package's version, commit and build in one phrase, for the reports'
    headers: "sphfluid 0.1.0 (commit 3a75a43, with local changes; GNU 12.2.0,
    Release, -march=native, double)"."""
    commit, dirty = git_state()
    info = _core.build_info
    where = "" if commit is None else (
        f"commit {commit[:7]}{', with local changes' if dirty else ''}; ")
    return (f"sphfluid {_core.__version__} ({where}{info['compiler']}, {info['build_type']}, "
            f"{target()}, {info['real']})")


def target() -> str:
    """What the running core was compiled for: "-march=native", "portable" (a
    source build for the compiler's default target) or, in a build with a core
    per SIMD level (a wheel), "avx512 core" and the like."""
    from ._dispatch import built_levels

    info = _core.build_info
    if info["march_native"]:
        return "-march=native"
    return f"{info['simd']} core" if built_levels() else "portable"


def run_metadata(sim) -> dict[str, Any]:
    """What is running: a JSON-ready dict for a Simulation.

    sphfluid_version, git_commit and git_dirty (None outside a checkout), build
    (the extension's compiler, build type, -march=native, OpenMP version and
    Real type), pair_precision and recip_root (the code paths the step takes on
    this CPU for this scene), method, threads and threads_in_use, scene_name and
    scene_hash (``scene_hash``)."""
    commit, dirty = git_state()
    solver = sim._solver
    return {
        "sphfluid_version": _core.__version__,
        "git_commit": commit,
        "git_dirty": dirty,
        "build": dict(_core.build_info),
        "pair_precision": "float" if solver.float_pairs else "double",
        "recip_root": bool(solver.recip_root),
        "method": sim.scene.method,
        "threads": sim.threads,
        "threads_in_use": sim.threads_in_use,
        "scene_name": sim.scene.name,
        "scene_hash": scene_hash(sim.scene),
    }
