"""SPlisHSPlasH on our dam break: a 2D scene with our tank (a box mesh, walls by
volume maps) and our fluid lattice, run without its GUI. Reads the configuration
JSON file that peers.py writes (the geometry, the spacing, the end time, and the
configuration: method, solver parameters, time step); reports on stdout as
child.py describes.

    python benchmarks/peers/splishsplash_dam_break.py CONFIG.json
"""
from __future__ import annotations

import json
import os
from importlib.metadata import version

import numpy as np
import pysplishsplash as sph
from child import Reporter, load_config

METHOD_IDS = {"WCSPH": 0, "DFSPH": 4}  # SPlisHSPlasH's simulationMethod enumeration


def write_tank(path: str, length: float, height: float) -> None:
    """The tank as a closed box mesh, x 0..L, y 0..H (z is flattened in 2D)."""
    corners = [(x, y, z) for z in (0.5, -0.5) for y in (0.0, height) for x in (0.0, length)]
    faces = [(1, 2, 3), (3, 2, 4), (5, 7, 6), (6, 7, 8), (1, 3, 5), (5, 3, 7),
             (2, 6, 4), (4, 6, 8), (1, 5, 2), (2, 5, 6), (3, 4, 7), (7, 4, 8)]
    with open(path, "w", encoding="utf-8") as f:
        f.writelines(f"v {x} {y} {z}\n" for x, y, z in corners)
        f.writelines(f"f {a} {b} {c}\n" for a, b, c in faces)


def time_step_settings(step: dict) -> dict:
    """The scene's time-step keys: a fixed dt, or its CFL rule with a largest dt."""
    if "fixed" in step:  # its CFL rule looks at the flow speed only, not at c0
        return {"cflMethod": 0, "timeStepSize": step["fixed"]}
    return {"cflMethod": 1, "cflFactor": step["cfl_factor"],
            "cflMaxTimeStepSize": step["cfl_max"]}


def scene(cfg: dict) -> dict:
    dx, length, height = cfg["spacing"], cfg["tank"], cfg["tank_height"]
    config = {"pause": False, "sim2D": True, "particleRadius": dx / 2,
              "simulationMethod": METHOD_IDS[cfg["method"]],
              "gravitation": [0.0, -cfg["g"], 0.0], "boundaryHandlingMethod": 2,
              "stopAt": cfg["end_time"], "enableZSort": True,
              **time_step_settings(cfg["time_step"])}
    tank = os.path.join(cfg["workdir"], "tank.obj")
    write_tank(tank, length, height)
    nx, ny = cfg["columns"], cfg["rows"]
    return {
        "Configuration": config,
        "Materials": [{"id": "Fluid", "density0": cfg["rho0"], "viscosityMethod": 1,
                       "viscosity": 0.01, "vorticityMethod": 0}],
        "RigidBodies": [{"geometryFile": tank, "isDynamic": False, "isWall": True,
                         "mapInvert": True, "mapThickness": 0.0,
                         # cells about one kernel support (2 dx) wide
                         "mapResolution": [int(np.ceil(length / (2 * dx))),
                                           int(np.ceil(height / (2 * dx))), 1]}],
        # a block's first particle sits one spacing in from its corner: start half a
        # spacing outside the tank so that the particles land on our lattice
        "FluidBlocks": [{"denseMode": 0, "start": [-dx / 2, -dx / 2, -0.5],
                         "end": [(nx + 0.5) * dx, (ny + 0.5) * dx, 0.5]}],
    }


def set_parameters(obj, values: dict) -> None:
    """Set parameters of obj by name and check that they took.

    Without its GUI, SPlisHSPlasH 2.19 does not read the solver's parameters (e.g.
    the WCSPH stiffness) from the scene file: it would run with its defaults.
    """
    took = {}
    for i in range(obj.numParameters()):
        name = obj.getName(i)
        if name not in values:
            continue
        kind = str(obj.getType(i))
        if "BOOL" in kind:
            set_value, get_value = obj.setValueBool, obj.getValueBool
        elif "UINT" in kind:
            set_value, get_value = obj.setValueUInt, obj.getValueUInt
        elif "INT" in kind:
            set_value, get_value = obj.setValueInt, obj.getValueInt
        else:
            set_value, get_value = obj.setValueFloat, obj.getValueFloat
        set_value(i, values[name])
        took[name] = get_value(i)
    wrong = {k: took.get(k) for k, v in values.items()
             if k not in took or not np.isclose(took[k], v, rtol=1e-6)}
    if wrong:
        raise RuntimeError(f"SPlisHSPlasH did not take the solver parameters {wrong}")


def main() -> None:
    cfg = load_config()
    reporter = Reporter(cfg)
    path = os.path.join(cfg["workdir"], "dam_break.json")
    with open(path, "w", encoding="utf-8") as f:
        json.dump(scene(cfg), f)
    base = sph.Exec.SimulatorBase()
    base.init(sceneFile=path, useGui=False, outputDir=os.path.join(cfg["workdir"], "output"),
              initialPause=False, useCache=False, stopAt=cfg["end_time"])
    base.initSimulation()
    set_parameters(sph.Simulation.getCurrent().getTimeStep(), cfg["parameters"])
    model = sph.Simulation.getCurrent().getFluidModel(0)
    clock = sph.TimeManager.getCurrent()
    n = model.numActiveParticles()
    reporter.start(cfg["method"], version("pysplishsplash"), n)
    # runSimulation() initialises the boundary (volume maps) and takes at least one
    # step: let it take exactly one, untimed, then step on here.
    base.setValueFloat(base.STOP_AT, 1e-12)
    base.runSimulation()
    base.setValueFloat(base.STOP_AT, cfg["end_time"])
    reporter.begin()
    while base.timeStepNoGUI():
        reporter.step(clock.getTime(),
                      lambda: np.asarray(model.getFieldBuffer("position"))[:n, :2].astype(float))
    reporter.finish(clock.getTime())
    base.cleanup()


if __name__ == "__main__":
    main()
