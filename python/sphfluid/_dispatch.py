"""Which native core an import of sphfluid loads.

A source build has one core, ``sphfluid._core``, compiled for the machine
that built it (``-march=native``) or for the compiler's default target. A
wheel (a build with ``SPHFLUID_DISPATCH=ON``) has one per SIMD level:
``_core_baseline`` (any x86-64), ``_core_avx2`` (x86-64-v3: AVX2 and FMA) and
``_core_avx512`` (x86-64-v4); ``sphfluid._cpu``, compiled for any x86-64,
says what the CPU has, and the fastest core the CPU runs becomes
``sphfluid._core`` (one core a process: the cores bind the same types). ``SPHFLUID_SIMD=baseline|avx2|avx512`` picks one instead
(for tests and comparisons); a level the CPU or the build lacks is an
ImportError that says so, never a crash on an unknown instruction.
``sphfluid._core.build_info["simd"]`` says which core runs.
"""
from __future__ import annotations

import importlib
import importlib.util
import os
import sys

LEVELS = ("avx512", "avx2", "baseline")  # fastest first
ENV = "SPHFLUID_SIMD"


def choose(features: dict[str, bool], wanted: str | None, built: set[str]) -> str:
    """The level to load: `wanted` (SPHFLUID_SIMD) if given, else the fastest
    level both built and run by a CPU with `features` ({"avx2": bool,
    "avx512": bool}); an ImportError if `wanted` cannot run here."""
    if wanted is not None and wanted.strip():
        level = wanted.strip().lower()
        if level not in LEVELS:
            raise ImportError(f"{ENV}={wanted!r}: expected baseline, avx2 or avx512")
        if level not in built:
            raise ImportError(f"{ENV}={level}: this build of sphfluid has no {level} core "
                              f"(it has: {', '.join(sorted(built))})")
        if level != "baseline" and not features.get(level, False):
            has = [lv for lv in LEVELS if lv == "baseline" or features.get(lv, False)]
            raise ImportError(f"{ENV}={level}: this CPU cannot run the {level} core "
                              f"(it runs: {', '.join(has)})")
        return level
    for level in LEVELS:
        if level in built and (level == "baseline" or features.get(level, False)):
            return level
    raise ImportError("sphfluid: no core this CPU can run was built")  # (baseline always is)


def built_levels() -> set[str]:
    """The levels this build has a core for (none: a build with one core)."""
    return {lv for lv in LEVELS if importlib.util.find_spec(f"sphfluid._core_{lv}") is not None}


def load() -> None:
    """Makes the chosen core ``sphfluid._core`` in a build with a core per level;
    in a build with one core, checks that SPHFLUID_SIMD does not ask for another."""
    wanted = os.environ.get(ENV)
    built = built_levels()
    if not built:
        if wanted is not None and wanted.strip():
            from . import _core

            level = _core.build_info["simd"]
            if wanted.strip().lower() != level:
                raise ImportError(
                    f"{ENV}={wanted!r}: this build of sphfluid has one core, compiled for "
                    f"{level}; {ENV} picks among the cores of a build with one per SIMD "
                    "level (the wheels; SPHFLUID_DISPATCH=ON)")
        return
    features = dict(importlib.import_module("sphfluid._cpu").features())
    core = importlib.import_module(f"sphfluid._core_{choose(features, wanted, built)}")
    sys.modules["sphfluid._core"] = core
    for sub in ("kernels", "walls"):
        sys.modules[f"sphfluid._core.{sub}"] = getattr(core, sub)
    setattr(sys.modules["sphfluid"], "_core", core)
