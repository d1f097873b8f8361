"""The typed stub (python/sphfluid/_core.pyi, _core/*.pyi) against the compiled module.

mypy's stubtest finds names missing on either side. pybind11 functions carry
their signatures in their docstrings only, where stubtest does not look: the
second test reads them there and compares parameter names, defaults and the
kinds of types with the stub's, and which properties can be set.
"""
from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
import sysconfig
from pathlib import Path

import numpy as np
import pytest
import sphfluid
from sphfluid import _core

PACKAGE = Path(sphfluid.__file__).resolve().parent
STUBS = {"sphfluid._core": PACKAGE / "_core.pyi",
         "sphfluid._core.kernels": PACKAGE / "_core" / "kernels.pyi",
         "sphfluid._core.walls": PACKAGE / "_core" / "walls.pyi"}
RUNTIME = {"sphfluid._core": _core, "sphfluid._core.kernels": _core.kernels,
           "sphfluid._core.walls": _core.walls}
FIX = ("the stub python/sphfluid/_core.pyi (and _core/*.pyi) no longer matches the built "
       "sphfluid._core: change the stub in the same commit as the bindings")


def test_the_package_ships_the_stubs():
    for path in [*STUBS.values(), PACKAGE / "py.typed"]:
        assert path.is_file(), f"{path} is missing from the installed package"


def test_stubtest_finds_no_difference(tmp_path):
    pytest.importorskip("mypy.stubtest", reason="needs mypy (the test extra: pip install .[test])")
    env = dict(os.environ)
    site = {Path(sysconfig.get_paths()[k]).resolve() for k in ("purelib", "platlib")}
    if PACKAGE.parent not in site:
        # A source tree (editable install): mypy cannot follow its import hook.
        env["MYPYPATH"] = str(PACKAGE.parent)
    out = subprocess.run([sys.executable, "-m", "mypy.stubtest", *STUBS], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=600, check=False)
    assert out.returncode == 0, f"{FIX}; mypy.stubtest says:\n{out.stdout}{out.stderr}"


# ---------------------------------------------------------------- signatures


def _split(params: str) -> list[str]:
    """Split a parameter list at the commas outside brackets and quotes."""
    parts, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(params):
        if quote:
            quote = "" if c == quote else quote
        elif c in "\"'":
            quote = c
        elif c in "[(":
            depth += 1
        elif c in "])":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(params[start:i].strip())
            start = i + 1
    parts.append(params[start:].strip())
    return [p for p in parts if p and p not in ("/", "*")]


def kind(annotation: str) -> str:
    """A type reduced to what both pybind11's spelling and the stub's must agree on."""
    # (a wheel's core is one of sphfluid._core_baseline, _avx2, _avx512 at run time)
    t = re.sub(r"\b(typing|numpy\.typing|numpy|np|collections\.abc|"
               r"sphfluid\._core(_baseline|_avx2|_avx512)?)\.", "", annotation.strip())
    if re.search(r"\b(ArrayLike|NDArray|ndarray)\b", t):
        return "array"
    if t.startswith("Literal[") and ("'" in t or '"' in t):
        return "str"
    if t.startswith("Annotated["):
        return kind(_split(t[len("Annotated["):-1])[0])
    if "[" in t:  # a container: its kind is enough
        return t.split("[")[0].lower()
    if "SupportsFloat" in t:
        return "float"
    if "SupportsInt" in t:
        return "int"
    return t.lower()


Signature = tuple[list[tuple[str, str, "str | None"]], str]  # [(name, kind, default)], return


def runtime_signature(doc: str | None, bound: bool) -> Signature | None:
    """The signature on a pybind11 docstring's first line, without self when bound."""
    m = re.match(r"\w*\((.*)\) -> (.+)", (doc or "").split("\n")[0])
    if m is None:
        return None
    params = []
    for p in _split(m.group(1))[1 if bound else 0:]:
        name, rest = p.split(": ", 1)
        annotation, _, default = rest.partition(" = ")
        params.append((name, kind(annotation), default or None))
    return params, kind(m.group(2))


def stub_signature(f: ast.FunctionDef) -> Signature:
    a = f.args
    args = [*a.posonlyargs, *a.args]
    defaults = [None] * (len(args) - len(a.defaults)) + list(a.defaults)
    params = [(p.arg, kind(ast.unparse(p.annotation)) if p.annotation else "?",
               ast.unparse(d) if d is not None else None)
              for p, d in zip(args, defaults) if p.arg != "self"]
    return params, kind(ast.unparse(f.returns)) if f.returns else "?"


def same_default(runtime: str | None, stub: str | None) -> bool:
    if runtime is None or stub is None:
        return runtime == stub
    try:
        return ast.literal_eval(runtime) == ast.literal_eval(stub)
    except (ValueError, SyntaxError):
        return runtime == stub


def compare(where: str, runtime, stub) -> list[str]:
    (r_params, r_ret), (s_params, s_ret) = runtime, stub
    problems = []
    if [p[0] for p in r_params] != [p[0] for p in s_params]:
        problems.append(f"{where}: parameters {[p[0] for p in r_params]} at run time, "
                        f"{[p[0] for p in s_params]} in the stub")
        return problems
    for (name, r_kind, r_default), (_, s_kind, s_default) in zip(r_params, s_params):
        if r_kind != s_kind and r_kind != "object":
            problems.append(f"{where}: {name} takes {r_kind} at run time, {s_kind} in the stub")
        if not same_default(r_default, s_default):
            problems.append(f"{where}: {name} defaults to {r_default} at run time, "
                            f"{s_default} in the stub")
    if r_ret != s_ret:
        problems.append(f"{where}: returns {r_ret} at run time, {s_ret} in the stub")
    return problems


class StubClass:
    """A stub class's methods, property getters and setters, and plain attributes."""

    def __init__(self, node: ast.ClassDef):
        self.methods: dict[str, ast.FunctionDef] = {}
        self.getters: dict[str, ast.FunctionDef] = {}
        self.setters: dict[str, ast.FunctionDef] = {}
        self.attributes: dict[str, str] = {}
        for item in node.body:
            if isinstance(item, ast.AnnAssign) and isinstance(item.target, ast.Name):
                self.attributes[item.target.id] = ast.unparse(item.annotation)
            elif isinstance(item, ast.FunctionDef):
                decorators = [ast.unparse(d) for d in item.decorator_list]
                if "property" in decorators:
                    self.getters[item.name] = item
                elif f"{item.name}.setter" in decorators:
                    self.setters[item.name] = item
                else:
                    self.methods[item.name] = item


def stub_tree(module: str) -> ast.Module:
    return ast.parse(STUBS[module].read_text(encoding="utf-8"))


def property_problems(where: str, prop: property, stub: StubClass, name: str) -> list[str]:
    getter = runtime_signature(prop.fget.__doc__, bound=True)
    if name in stub.attributes:  # a plain attribute: read and written with one type
        annotation = stub.attributes[name]
        if annotation.startswith("ClassVar"):
            return []
        s_get = ([], kind(annotation))
        s_set = ([("value", kind(annotation), None)], "none")
    elif name in stub.getters:
        s_get = stub_signature(stub.getters[name])
        s_set = stub_signature(stub.setters[name]) if name in stub.setters else None
    else:
        return []  # stubtest reports it missing
    problems = compare(f"{where} (read)", getter, s_get) if getter else []
    if prop.fset is None and s_set is not None:
        problems.append(f"{where}: read-only at run time, can be set in the stub")
    elif prop.fset is not None and s_set is None:
        problems.append(f"{where}: can be set at run time, read-only in the stub")
    elif prop.fset is not None:
        setter = runtime_signature(prop.fset.__doc__, bound=True)
        if setter:  # the value's name is free: compare its type only
            r_params, _ = setter
            s_params = [(r_params[0][0], *s_set[0][0][1:])] if s_set[0] else []
            problems += compare(f"{where} (set)", (r_params, setter[1]), (s_params, s_set[1]))
    return problems


def test_signatures_match_the_bindings():
    problems = []
    for module, runtime in RUNTIME.items():
        tree = stub_tree(module)
        functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
        classes = {n.name: StubClass(n) for n in tree.body if isinstance(n, ast.ClassDef)}
        for name, obj in vars(runtime).items():
            where = f"{module}.{name}"
            if callable(obj) and not isinstance(obj, type) and name in functions:
                sig = runtime_signature(obj.__doc__, bound=False)
                if sig is not None:
                    problems += compare(where, sig, stub_signature(functions[name]))
            elif isinstance(obj, type) and name in classes:
                stub = classes[name]
                problems += [f"{where}.{member}: in the stub, not at run time"
                             for member in [*stub.methods, *stub.getters, *stub.attributes]
                             if not hasattr(obj, member)]
                for member, value in vars(obj).items():
                    if member.startswith("__") and member != "__init__":
                        continue
                    if isinstance(value, property):
                        problems += property_problems(f"{where}.{member}", value, stub, member)
                    elif callable(value) and member in stub.methods:
                        sig = runtime_signature(value.__doc__, bound=True)
                        if sig is not None:
                            problems += compare(f"{where}.{member}", sig,
                                                stub_signature(stub.methods[member]))
    assert not problems, FIX + ":\n" + "\n".join(problems)


def test_array_properties_have_the_stubbed_dtypes():
    solver = _core.Solver(_core.SimParams(), np.array([[0.1, 0.2], [0.3, 0.2]]), np.zeros((2, 2)),
                          np.array([[[-0.5, 0.0], [0.5, 0.0]]]))
    solver.compute_forces()
    stub = StubClass(next(n for n in stub_tree("sphfluid._core").body
                          if isinstance(n, ast.ClassDef) and n.name == "Solver"))
    arrays = {name: ast.unparse(f.returns) for name, f in stub.getters.items()
              if f.returns is not None and ast.unparse(f.returns).startswith("NDArray[")}
    assert {"positions", "velocities", "accelerations", "densities", "pressures", "ids",
            "walls"} <= set(arrays)
    for name, annotation in arrays.items():
        dtype = np.dtype(annotation[len("NDArray[np."):-1])
        value = getattr(solver, name)
        assert value.dtype == dtype, (f"{FIX}: Solver.{name} is {value.dtype} at run time, "
                                      f"{annotation} in the stub")


def test_the_build_info_keys_match_the_stub():
    tree = stub_tree("sphfluid._core")
    typed = next(n for n in tree.body if isinstance(n, ast.ClassDef) and n.name == "_BuildInfo")
    keys = {item.target.id for item in typed.body if isinstance(item, ast.AnnAssign)}
    assert set(_core.build_info) == keys, f"{FIX}: build_info's keys"
