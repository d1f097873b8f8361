# Types of the compiled module sphfluid._core (cpp/bindings.cpp, cpp/bind_solver.cpp);
# its submodules are typed in _core/kernels.pyi and _core/walls.pyi. The contract
# the bindings keep: tests/test_stub.py checks this file against the built module.
from collections.abc import Sequence
from typing import Any, ClassVar, Literal, TypedDict, type_check_only

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sphfluid._core import kernels as kernels
from sphfluid._core import walls as walls

__version__: str
has_openmp: bool

@type_check_only
class _BuildInfo(TypedDict):
    compiler: str  # e.g. "GNU 12.2.0"
    build_type: str  # CMake build type, e.g. "Release"
    march_native: bool  # built with -march=native
    openmp: int | None  # the _OPENMP date, None without OpenMP
    simd: Literal["native", "baseline", "avx2", "avx512"]  # the SIMD level compiled for
    real: Literal["double", "float"]  # the core's Real
    sanitize: str  # the -fsanitize= list of a checking build, "" otherwise

build_info: _BuildInfo


@type_check_only
class _Pybind11Type(type):
    """The metaclass of every class bound with pybind11 (pybind11_builtins.pybind11_type)."""

class InstabilityError(RuntimeError):
    """A step went non-finite or tripped the guard; the message names the check."""

class Method(metaclass=_Pybind11Type):
    """The SPH method of a run."""

    seed: ClassVar[Method]
    wcsph: ClassVar[Method]
    dfsph: ClassVar[Method]
    __members__: ClassVar[dict[str, Method]]
    def __init__(self, value: int) -> None: ...
    @property
    def name(self) -> str: ...
    @property
    def value(self) -> int: ...
    def __eq__(self, other: object) -> bool: ...
    def __ne__(self, other: object) -> bool: ...
    def __hash__(self) -> int: ...
    def __int__(self) -> int: ...
    def __index__(self) -> int: ...
    def __getstate__(self) -> int: ...
    def __setstate__(self, state: int, /) -> None: ...

class SimParams(metaclass=_Pybind11Type):
    """Physical and numerical constants of a run (SI units)."""

    def __init__(self) -> None: ...
    method: Method
    # wcsph
    c0: float  # speed of sound, m/s
    alpha: float  # artificial viscosity coefficient
    background_pressure: float  # added to the Tait EOS (sum clamped at 0), Pa
    spacing: float  # lattice spacing the walls mirror, m (0: a continuum)
    continuity: bool  # density from the continuity equation (else the summation)
    delta: float  # with continuity: density diffusion coefficient (0: none)
    shifting: float  # with continuity: particle shifting coefficient (0: none)
    shift_confined: bool  # with continuity: shift only a flow without a free surface at the start
    surface_pressure: bool  # with continuity: W26b (pressure floored at a free surface), not W26
    reconstruct_viscosity: bool  # with continuity: W30 (the artificial viscosity reconstructed)
    quintic_pressure: bool  # with continuity: W31 (the pressure on the quintic spline)
    # dfsph
    density_tolerance: float  # the constant-density solve's mean density error / rho0
    divergence_tolerance: float  # the divergence-free solve's mean density change a step / rho0
    min_iterations: int  # each solve's least iterations
    max_iterations: int  # each solve's most iterations (then the step goes on; counted)
    # the fluid and its particles
    h: float  # smoothing length (kernel support), m
    mass: float  # particle mass, kg per metre of depth
    rho0: float  # rest density, kg/m^3
    k: float  # gas constant of p = k (rho - rho0), m^2/s^2
    eta: float  # dynamic viscosity, Pa s
    sigma: float  # surface tension coefficient, N
    surface_threshold: float  # |grad c| above which surface tension acts, 1/m (< 0: 0.323 / h)
    @property
    def gravity(self) -> list[float]:
        """Body acceleration [gx, gy], m/s^2."""
    @gravity.setter
    def gravity(self, value: Sequence[float], /) -> None: ...
    @property
    def domain_min(self) -> list[float]:
        """Lower corner of the domain [x, y], m."""
    @domain_min.setter
    def domain_min(self, value: Sequence[float], /) -> None: ...
    @property
    def domain_max(self) -> list[float]:
        """Upper corner of the domain [x, y], m."""
    @domain_max.setter
    def domain_max(self, value: Sequence[float], /) -> None: ...
    @property
    def periodic(self) -> list[bool]:
        """Periodic axes [x, y]: the domain wraps along them."""
    @periodic.setter
    def periodic(self, value: Sequence[bool], /) -> None: ...
    @property
    def effective_surface_threshold(self) -> float:
        """The surface threshold in use, 1/m."""
    @property
    def sound_speed(self) -> float:
        """Speed of sound of the method's equation of state, m/s."""
    # walls
    ghost_mass_ratio: float  # wall ghost mass / particle mass
    ghost_density_ratio: float  # wall ghost density / rest density
    restitution: float  # normal restitution of the wall reflection, in [0, 1]
    # running
    threads: int  # OpenMP threads (0: the OpenMP default)
    float_pairs: bool  # the seed's pair forces in single precision where the cell clusters run
    cfl: float  # CFL factor of the adaptive time step
    dt_max: float  # cap on the adaptive time step, s (0: none)
    # the guard
    surface_length: float  # initial free-surface length, m, for the surface-energy bound
    guard: bool  # check density, speed and energy after every step (non-finite: always)
    guard_density_ratio: float  # trip when rho > ratio * rho0
    guard_speed_factor: float  # trip when |v| > factor * speed of sound
    guard_energy_factor: float  # trip when kinetic energy > factor * energy budget
    max_retries: int  # on a trip, retry the step with dt/2, dt/4, ... this many times

class Solver(metaclass=_Pybind11Type):
    """The SPH method of `params` on a set of particles and walls."""

    def __init__(self, params: SimParams, positions: ArrayLike, velocities: ArrayLike,
                 walls: ArrayLike, ids: ArrayLike | None = None) -> None:
        """Positions and velocities (n, 2), walls (s, 2, 2) as [[x1, y1], [x2, y2]], ids (n,)
        (default 0..n-1). Particles outside the domain are removed (and counted) at once."""
    # stepping (each releases the GIL; InstabilityError on a blow-up)
    def step(self, dt: float, n: int = 1) -> None:
        """Advance n steps of size dt, s."""
    def step_adaptive(self, n: int = 1) -> None:
        """Advance n steps, each with the largest stable dt."""
    def advance_adaptive(self, t_end: float, max_steps: int) -> int:
        """Adaptive steps until time reaches t_end (landing on it) or max_steps; the steps taken."""
    def compute_forces(self) -> None:
        """Density, pressure and acceleration for the current state; nothing moves."""
    # changing the state
    def set_state(self, positions: ArrayLike, velocities: ArrayLike,
                  ids: ArrayLike | None = None) -> None:
        """Replace all particles (n may change); ids default to 0..n-1."""
    def settle_fluid(self) -> None:
        """The particles are the scene's fluid as its regions filled the lattice: wcsph's
        continuity density compresses them along gravity to its hydrostatic start
        (docs/method-wcsph.md, W23b); other methods leave them."""
    def add_particles(self, positions: ArrayLike, velocities: ArrayLike) -> None:
        """Append particles (n, 2) with fresh ids; those outside the domain are removed."""
    def set_walls(self, walls: ArrayLike) -> None:
        """Replace the wall segments (s, 2, 2); takes effect at once."""
    def set_wall_velocities(self, velocities: ArrayLike) -> None:
        """The walls' surface velocities (s, 2), along each wall (a sliding lid); zero by
        default and after set_walls."""
    def set_wall_motions(self, motions: list[dict[str, Any]], motion_of: Sequence[int]) -> None:
        """Moving walls: each motion a dict of tables 'x', 'y' (the drawn position's
        translation, m) and 'angle' (radians, counterclockwise about 'about' [x, y],
        which moves with it), each [[t, value], ...]; motion_of[k] is segment k's
        motion or -1. The walls as they are now are the drawn ones."""
    def set_damping(self, zones: list[dict[str, Any]]) -> None:
        """Replace the damping zones, each a dict with 'from' and 'to' [x, y] (m) and
        'strength' (1/s): every step a particle past the line through 'from' (across
        from -> to) keeps 1 - dt s^2 strength of its velocity (at least 0), s its
        distance past the line over |to - from|, 1 beyond 'to'."""
    def set_flows(self, emitters: list[dict[str, Any]], sinks: list[dict[str, Any]],
                  spacing: float, outlets: list[dict[str, Any]] = []) -> None:
        """Replace the emitters (and inlets), sinks and outlets; they act from the
        next step, the emitters' rows on the lattice of `spacing` (m); the inlets'
        buffers are placed now. An emitter is a dict with 'at' [x, y], 'direction'
        [dx, dy], 'width' (m), 'times' and 'speeds' (a table, linear between its
        times), 'start' and 'stop' (s), and for an inlet 'buffer' (its depth behind
        'at', m); a sink one with 'polygon' [[x, y], ...] or 'centre' [x, y] and
        'radius'; an outlet one with 'at', 'direction' (out of the fluid), 'width'
        and 'depth' (m)."""
    def snapshot(self) -> dict[str, Any]:
        """Everything the next step depends on: 'fields' (each particle field's numbers
        in storage order), the clock and counts, the guard's budget, 'method' (the
        method's own numbers). restore() continues from it bit for bit."""
    def restore(self, snapshot: dict[str, Any]) -> None:
        """Continue from a snapshot() of a solver with the same parameters (ValueError
        when its fields are not this run's)."""
    @property
    def threads(self) -> int:
        """OpenMP threads the step may use (0: the OpenMP default)."""
    @threads.setter
    def threads(self, value: int, /) -> None: ...
    # the particles: read-only views whose base is the solver, in cell order
    @property
    def positions(self) -> NDArray[np.float64]:
        """(n, 2), m."""
    @property
    def velocities(self) -> NDArray[np.float64]:
        """(n, 2), m/s."""
    @property
    def accelerations(self) -> NDArray[np.float64]:
        """(n, 2) of the last force evaluation, m/s^2."""
    @property
    def densities(self) -> NDArray[np.float64]:
        """(n,) of the last evaluation, kg/m^3."""
    @property
    def pressures(self) -> NDArray[np.float64]:
        """(n,) of the last evaluation, Pa."""
    @property
    def ids(self) -> NDArray[np.int64]:
        """(n,) stable particle ids."""
    @property
    def walls(self) -> NDArray[np.float64]:
        """(s, 2, 2) copy of the wall segments, m."""
    @property
    def n_particles(self) -> int: ...
    @property
    def params(self) -> SimParams:
        """A copy of the run's parameters (changing it changes nothing in the run)."""
    # the run so far
    @property
    def time(self) -> float:
        """Simulated time, s."""
    @property
    def step_count(self) -> int: ...
    @property
    def last_dt(self) -> float:
        """Time step of the last step, s."""
    @property
    def last_dt_limit(self) -> str:
        """What limited the last step: fixed, cfl, force, viscous or dt_max (a step shortened
        to land on an end time keeps that label)."""
    @property
    def removed_particles(self) -> int:
        """Particles removed for leaving the domain."""
    @property
    def balance(self) -> dict[str, int]:
        """The particle count's balance: 'placed' + 'in' (emitters) - 'sunk' - 'lost'
        (left the domain) = n_particles."""
    @property
    def wall_crossings(self) -> int:
        """Wall crossings the wall collisions stopped (each bounce, and each stop in front of
        a wall), over the run."""
    @property
    def retried_steps(self) -> int:
        """Steps retried with a halved time step."""
    @property
    def retry_log(self) -> list[str]:
        """Messages of the most recent retries, oldest first."""
    @property
    def energy_budget(self) -> float:
        """Energy the scene can supply, J per m of depth (guard)."""
    @property
    def energy_removed(self) -> float:
        """Kinetic energy carried out of the domain by removed particles, J per m of depth."""
    @property
    def surface_energy(self) -> float:
        """wcsph with surface tension: sigma x surface length at the last evaluation, J per m
        of depth; 0 otherwise."""
    @property
    def solve_stats(self) -> dict[str, float]:
        """dfsph: the last step's iterations and mean errors of both pressure solves, the
        solves stopped at the most iterations and the iterations taken over the run."""
    # what runs and what it costs
    @property
    def features(self) -> int:
        """Bit set of the active optional terms: 1 viscosity, 2 surface tension, 4 walls,
        8 periodic axes."""
    @property
    def float_pairs(self) -> bool:
        """Whether the pair forces run in single precision (asked for, seed, cell clusters)."""
    @property
    def quintic_pressure(self) -> bool:
        """wcsph's continuity density: whether the last evaluation's pressure force ran on
        W31's quintic spline (asked for, and the flow not shifted)."""
    @property
    def recip_root(self) -> bool:
        """Whether the seed's double pair forces by cell clusters take 1/r from rsqrt14 and
        two Newton steps instead of a square root and a division (chosen by CPU)."""
    @property
    def threads_in_use(self) -> int:
        """Threads the step's loops use now: `threads`, or 1 below 1,000 particles."""
    @property
    def neighbour_pairs(self) -> int:
        """Stored neighbour pairs (i, j != i) of the last evaluation."""
    @property
    def memory_bytes(self) -> dict[str, int]:
        """Heap bytes held by the solver's arrays, by part (capacity included)."""
    @property
    def sort_counts(self) -> dict[str, int]:
        """Sorts by cell so far: unchanged, moved, moved_in_parts and permuted."""
    def phase_seconds(self) -> dict[str, float]:
        """Wall-clock seconds spent in each phase of the step since the last reset."""
    def reset_phase_seconds(self) -> None: ...
