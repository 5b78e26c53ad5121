"""Any robot, any behaviour: hybrid simulations, sweeps, MCAP logs and plots for a robot of
your own (issue 17), through the Rust crate ``selfmanip-sim``.

* :func:`simulate` — one execution of a robot (a :class:`selfmanip.Robot` or a description
  file) driven by a behaviour (a TOML/JSON file or a dict of the schema in
  ``docs/behaviours.md``; ``None``: no actuation) from ``q0`` → an :class:`Execution` with its
  status, word, events, segments, ``trajectory(dt)``, ``energy_report()``, ``to_mcap(path)``
  and ``plot(path)``.
* :func:`sweep` — a grid over named parameters (behaviour parameters such as ``kp_push``, any
  description, terrain, initial-state or option field by path such as
  ``legs.leg.links[1].length_m``) on a pool of threads → DataFrame-ready columns with a status
  and an error per point. Called with a strategy (``selfmanip.sweep("++", t2=...)``) or with
  no robot, it is the RHex leap sweep of :mod:`selfmanip.leap`, unchanged.
* :func:`periodic_orbit` — the periodic orbit of a gait through the apex section, found by
  Newton shooting on the engine's own derivatives: fixed point, period, monodromy matrix,
  Floquet multipliers and a stability verdict (``docs/periodic-orbits.md``).
* ``simulate(..., sensitivity=True)``: the execution's state Jacobian ``dx(t_end)/dx(0)``
  (``Execution.state_jacobian``, through every event, an apex passed on the way included)
  and each event's saltation matrix (``execution.events[i]["saltation"]``, ``None`` with
  ``"saltation_reason"`` where the engine flags it); with ``parameters=[path, ...]`` the
  derivatives with respect to behaviour and description parameters by path.
* A Python callable as controller, ``controller=lambda t, q, qd, mode: tau``: the slow escape
  hatch. Each evaluation takes the GIL and crosses the FFI (seven per integration step), so a
  run is one to two orders of magnitude slower than the same law as a behaviour file; the
  callable must be a pure function of its arguments (the engine evaluates it at trial states
  and again when sampling the trajectory). ``mode`` is the contact-mode label in the robot's
  contact order (``"10"``: the first contact down). An exception it raises stops the run and
  surfaces as :class:`selfmanip.errors.ControllerError` (the original is ``__cause__``); a
  result of the wrong length or with a NaN as :class:`selfmanip.errors.InvalidInputError`
  naming ``controller``. Free massless joints have no dynamics: a Python controller leaves
  them unaccelerated (prescribe their motion with a behaviour instead).

Every default (final time, tolerances, event and step budgets, the sample interval of logs)
is the Rust crate's: arguments left at :data:`DEFAULT` are not sent. Runs release the GIL and
stop on Ctrl-C (``KeyboardInterrupt``) within one integration step.
"""

from __future__ import annotations

import functools
import math
import numbers
import os
from dataclasses import dataclass
from dataclasses import field as dataclass_field
from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping, Sequence, Union, overload

import numpy as np

from . import _checks, _facade, _native
from ._facade import COMPLETE_STATUSES, DEFAULT, _Default, failure_summary
from .errors import InvalidInputError, InvalidTypeError
from .robot import Robot, description_format

if TYPE_CHECKING:
    import matplotlib.figure

__all__ = ["Execution", "EnergyReport", "SimTrajectory", "simulate", "sweep", "simulation_sweep", "scenario",
           "defaults", "settable_names", "COMPLETE_STATUSES", "failure_summary", "PeriodicOrbit", "periodic_orbit"]

RobotLike = Union[Robot, str, "os.PathLike[str]", Mapping[str, Any]]
BehaviourLike = Union[str, "os.PathLike[str]", Mapping[str, Any], None]
TerrainLike = Union[str, Mapping[str, Any], None]
Controller = Callable[[float, np.ndarray, np.ndarray, str], Sequence[float]]


@functools.lru_cache(maxsize=1)
def _defaults() -> dict[str, Any]:
    return dict(_native.sim_defaults())


def defaults() -> dict[str, Any]:
    """The Rust defaults: ``t_final_s``, ``sample_dt_s`` (logs and plots) and ``options`` (every
    field of ``SimOptions``, the names ``**options`` of :func:`simulate` accepts)."""
    import copy

    return copy.deepcopy(_defaults())


@dataclass(frozen=True)
class EnergyReport:
    """``E1 - E0 = W + W_d + W_fr - L`` over an execution: kinetic plus potential energy (gravity's
    and the joint springs') at the start and the end, the joint torques' work
    ``W = int tau . thetadot dt`` (free massless joints carry no load but their own
    spring-damper's), the passive dampers' work ``W_d = -int sum c thetadot^2 dt`` and the
    sliding contacts' kinetic friction work ``W_fr = int f_fr . qdot dt`` (both never positive)
    and the impact losses ``L`` (sum of ``T- - T+`` over the touchdowns);
    ``residual_j = E1 - E0 - W - W_d - W_fr + L`` (zero up to the integration tolerance)."""

    initial_j: float
    final_j: float
    joint_work_j: float
    damping_work_j: float
    friction_work_j: float
    impact_loss_j: float
    residual_j: float


@dataclass(frozen=True)
class SimTrajectory:
    """Samples of an execution from its own dense output: ``t_s`` (n), ``q``/``qd`` (n x nq,
    columns ``q_names``), ``tau`` (n x joints: the torques the behaviour or controller applied),
    ``mode`` (labels), ``contact_points_m``/``contact_forces_n`` (n x contacts x 2, world
    ``(x, z)`` NED; force of the ground on the robot; NaN where a contact is not active)."""

    q_names: list[str]
    contacts: list[str]
    t_s: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    tau: np.ndarray
    mode: list[str]
    contact_points_m: np.ndarray
    contact_forces_n: np.ndarray


class Execution:
    """One execution of :func:`simulate`.

    ``status`` (``final_time``, ``apex``, ``zeno``, ``step_budget``, …), ``word`` (the contact
    cells visited, in the robot's own contact order), ``events`` (dicts: ``t_s``, ``kind`` —
    ``touchdown``, ``liftoff``, ``slip``, ``stick``, ``apex``, ``fold``, … —, ``mode_before``,
    ``mode_after``, ``contacts`` that fired, ``energy_loss_j``, and one entry per contact
    site in the order of ``SimTrajectory.contacts`` -- ``None`` or the world NED ``[x, z]`` of
    the ground's action on the robot -- in ``force_n``, the force right after the event in N,
    and ``impulse_n_s``, the impulse of an impact in N s, all ``None`` for the other kinds;
    ``docs/conventions.md``), ``segments`` (dicts ``t0_s``, ``t1_s``, ``mode``),
    ``outcome`` (apex, landing, end state, flight time, impact losses).

    Picklable and deep-copyable (for process pools): a copy carries this data and replays the
    engine run, the same bit for bit, when a method first needs it (see :meth:`__getstate__`);
    a run with a Python controller pickles when its controller does."""

    def __init__(self, native: Any, robot_name: str = "", sensitivity: bool = False,
                 parameters: Sequence[str] = ()):
        self._native = native
        self.robot_name = robot_name
        self._status = str(native.status)
        self._reason = str(native.reason)
        self._word = list(native.word)
        self._q_names = list(native.q_names)
        self._labels = list(native.labels)
        self.outcome: dict[str, Any] = dict(native.outcome())
        self.events: list[dict[str, Any]] = list(native.events())
        self.segments: list[dict[str, Any]] = list(native.segments())
        #: ``dx(t_end)/dx(0)`` over the state ``(q, qd)`` (``2 nq x 2 nq``) when run with
        #: ``sensitivity=True`` and every event's saltation matrix is defined; else ``None``.
        self.state_jacobian: np.ndarray | None = None
        self.one_sided_state_jacobian: np.ndarray | None = None
        #: The parameters asked for with ``parameters=[...]`` (names or paths), and
        #: ``dx(t_end)/dp`` over them (``2 nq x len(parameters)``, one column per name), or
        #: ``None`` when not formed (``parameter_reason`` says why). A name without an exact
        #: derivative yet has a NaN column and its reason in ``parameter_not_differentiated``.
        self.parameters: list[str] = list(parameters)
        self.parameter_jacobian: np.ndarray | None = None
        self.parameter_reason: str | None = None
        self.parameter_not_differentiated: dict[str, str] = {}
        if sensitivity:
            self._attach_sensitivity(native.sensitivity())
        if self.parameters:
            p = native.parameter_sensitivity(self.parameters)
            self.parameter_jacobian = p["parameter_jacobian"]
            self.parameter_reason = p["reason"]
            self.parameter_not_differentiated = {
                n: why for n, why in zip(self.parameters, p["not_differentiated"]) if why is not None}
            for ev, g in zip(self.events, p["event_time_gradients"]):
                ev["parameter_time_gradient"] = g

    def _attach_sensitivity(self, s: Mapping[str, Any]) -> None:
        """Each event gets ``saltation`` (``2 nq x 2 nq`` or ``None``), ``saltation_status``
        (``defined``, ``grazing``, ``simultaneous``, ``one_sided``, ``unsupported``),
        ``saltation_reason``, ``time_gradient`` (``dt_event/dx(0)``) and ``one_sided`` (where
        several guards fired at once: one ``{"order", "saltation"}`` per order of their
        contacts); ``one_sided_state_jacobian`` is the run's derivative for the first
        orders where only ``one_sided`` events leave ``state_jacobian`` undefined."""
        self.state_jacobian = s["state_jacobian"]
        self.one_sided_state_jacobian = s["one_sided_state_jacobian"]
        sens = list(s["events"])
        for ev in self.events:
            match = next((e for e in sens if e["t_s"] == ev["t_s"] and e["kind"] == ev["kind"]), None)
            ev["saltation"] = None if match is None else match["saltation"]
            ev["saltation_status"] = "unsupported" if match is None else match["status"]
            ev["saltation_reason"] = ("no sensitivity was formed for this event" if match is None
                                      else match["reason"])
            ev["time_gradient"] = None if match is None else match["time_gradient"]
            ev["one_sided"] = [] if match is None else list(match["one_sided"])

    def __getstate__(self) -> dict[str, Any]:
        """``pickle`` and ``copy``: everything but the native run, which is kept as the recipe
        that replays it (its scenario and controller; the engine is deterministic, so the
        replay is the same run bit for bit) and replayed on the first call that needs it
        (:meth:`trajectory`, :meth:`energy_report`, :meth:`to_mcap`, :meth:`plot`)."""
        state = self.__dict__.copy()
        native = state.pop("_native")
        if native is not None:
            state["_replay"] = native.__reduce__()
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._native = None

    @property
    def _run(self) -> Any:
        """The native run (replayed from its scenario after unpickling)."""
        if self._native is None:
            replay, args = self._replay
            self._native = replay(*args)
        return self._native

    @property
    def status(self) -> str:
        return self._status

    @property
    def reason(self) -> str:
        """Why the run ended short of its final time or apex, in words ("" if it did not)."""
        return self._reason

    @property
    def word(self) -> list[str]:
        return list(self._word)

    @property
    def word_string(self) -> str:
        """The word joined by ``-``."""
        return "-".join(self.word)

    @property
    def q_names(self) -> list[str]:
        return list(self._q_names)

    @property
    def labels(self) -> list[str]:
        """The contacts of the mode labels, in order."""
        return list(self._labels)

    @property
    def t_end_s(self) -> float:
        return float(self.outcome["t_end_s"])

    @property
    def q_end(self) -> np.ndarray:
        return np.asarray(self.outcome["q_end"], dtype=float)

    @property
    def qd_end(self) -> np.ndarray:
        return np.asarray(self.outcome["qd_end"], dtype=float)

    @property
    def apex(self) -> dict[str, float] | None:
        """The highest point of the first flight (``t_s, x_m, z_m, phi_rad, xdot_m_s, …``)."""
        return self.outcome.get("apex")

    @property
    def landing(self) -> dict[str, Any] | None:
        """The first touchdown after the first flight: ``before`` (body state), ``contacts``,
        ``mode_after``, ``energy_loss_j``."""
        return self.outcome.get("landing")

    @property
    def complete(self) -> bool:
        """Whether the run reached its final time or its apex."""
        return self.status in COMPLETE_STATUSES

    def __repr__(self) -> str:
        return (f"Execution({self.robot_name!r}: {self.status} at t={self.t_end_s:.4g} s, "
                f"{len(self.events)} events, word {self.word_string})")

    def trajectory(self, dt: float | _Default = DEFAULT) -> SimTrajectory:
        """Samples every ``dt`` seconds (default: ``defaults()["sample_dt_s"]``) and at the end."""
        d = self._run.trajectory(None if dt is DEFAULT else _checks.real("dt", dt))
        return SimTrajectory(q_names=list(d["q_names"]), contacts=list(d["contacts"]), t_s=d["t_s"], q=d["q"],
                             qd=d["qd"], tau=d["tau"], mode=list(d["mode"]),
                             contact_points_m=d["contact_points_m"], contact_forces_n=d["contact_forces_n"])

    def energy_report(self) -> EnergyReport:
        """``E1 - E0 = W + W_d + W_fr - L`` (see :class:`EnergyReport`)."""
        return EnergyReport(**{k: float(v) for k, v in self._run.energy_report().items()})

    def to_mcap(self, path: str | os.PathLike[str], dt: float | _Default = DEFAULT,
                metadata: Mapping[str, str] | None = None) -> str:
        """Writes an MCAP log that opens in Foxglove (a frame per body and link, contact points
        and forces, modes, events; topics in ``crates/selfmanip-sim/src/mcap.rs``), sampled
        every ``dt``; returns the path."""
        md = {str(k): str(v) for k, v in (metadata or {}).items()}
        if self.robot_name:
            md.setdefault("robot", self.robot_name)
        self._run.write_mcap(os.fspath(path), None if dt is DEFAULT else _checks.real("dt", dt), md)
        return os.fspath(path)

    def plot(self, path: str | os.PathLike[str] | None = None, dt: float | _Default = DEFAULT,
             title: str | None = None) -> "matplotlib.figure.Figure":
        """Height, pitch and joint angles, and contact forces against time, events marked
        (:func:`selfmanip.plots.execution_figure`); saved as PNG when ``path`` is given."""
        from .plots import execution_figure

        return execution_figure(self, path, dt=dt, title=title)


def _robot(robot: Any) -> tuple[Any, str]:
    if isinstance(robot, Robot):
        return robot._native, robot.name
    if isinstance(robot, (str, os.PathLike)):
        p = os.fspath(robot)
        description_format(p, field="robot")
        if not os.path.exists(p):
            raise FileNotFoundError(f"robot description not found: {p}")
        return p, os.path.splitext(os.path.basename(p))[0]
    if isinstance(robot, Mapping):
        return dict(robot), str(robot.get("name", ""))
    raise InvalidTypeError(f"`robot` must be a selfmanip.Robot, a description file or a dict, got "
                           f"{type(robot).__name__}", "robot")


def _behaviour(behaviour: Any) -> Any:
    if behaviour is None or isinstance(behaviour, Mapping):
        return None if behaviour is None else dict(behaviour)
    if isinstance(behaviour, (str, os.PathLike)):
        p = os.fspath(behaviour)
        if not os.path.exists(p):
            raise FileNotFoundError(f"behaviour file not found: {p}")
        return p
    raise InvalidTypeError(f"`behaviour` must be a file path, a dict or None, got {type(behaviour).__name__}",
                           "behaviour")


def _names(field: str, value: Any) -> list[str] | None:
    if value is None:
        return None
    if isinstance(value, str):
        return [v.strip() for v in value.split(",") if v.strip()]
    if not all(isinstance(v, str) for v in value):
        raise InvalidTypeError(f"`{field}` must be contact or coordinate names", field)
    return list(value)


def scenario(robot: RobotLike, behaviour: BehaviourLike, q0: Sequence[float], qd0: Sequence[float] | None = None,
             terrain: TerrainLike = None, t_final: float | _Default = DEFAULT, stop_at: str | None | _Default = DEFAULT,
             *, contacts: Sequence[str] | str | None = None, solve: Sequence[str] | str | None = None,
             params: Mapping[str, Any] | None = None, **options: Any) -> Any:
    """The native scenario :func:`simulate` and :func:`sweep` run (arguments as there)."""
    native_robot, _ = _robot(robot)
    opts = dict(options)
    if t_final is not DEFAULT:
        opts["t_final_s"] = _checks.real("t_final", t_final)
    if stop_at is not DEFAULT:
        if stop_at not in (None, "apex"):
            raise InvalidInputError(f"`stop_at`: expected None or \"apex\", got {stop_at!r}", "stop_at")
        opts["stop_at_apex"] = stop_at == "apex"
    s = _native.Scenario(native_robot, _behaviour(behaviour), _checks.vector("q0", q0),
                         None if qd0 is None else _checks.vector("qd0", qd0), terrain,
                         _names("contacts", contacts), _names("solve", solve), opts)
    for name, value in _checks.mapping("params", params).items():
        s.set(name, _plain(name, value))
    return s


def _plain(name: str, value: Any) -> Any:
    """numpy scalars as Python numbers (the FFI takes plain Python objects)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


def simulate(robot: RobotLike, behaviour: BehaviourLike, q0: Sequence[float], qd0: Sequence[float] | None = None,
             terrain: TerrainLike = None, t_final: float | _Default = DEFAULT, stop_at: str | None | _Default = DEFAULT,
             *, controller: Controller | None = None, contacts: Sequence[str] | str | None = None,
             solve: Sequence[str] | str | None = None, params: Mapping[str, Any] | None = None,
             sensitivity: bool = False, parameters: Sequence[str] | None = None,
             **options: Any) -> Execution:
    """One execution of ``robot`` driven by ``behaviour`` from ``q0`` (``[joint angles..., x, z,
    phi]``, NED: z down) and ``qd0`` (default: at rest), on ``terrain`` (``None``: flat ground;
    ``"flat"``, or a dict such as ``{"kind": "ledge", "height_m": 0.04, "distance_m": 0.5}``;
    kinds ``flat``, ``incline``, ``ledge``, ``stairs``).

    ``robot``: a :class:`selfmanip.Robot`, a description file or a description dict.
    ``behaviour``: a behaviour file (TOML/JSON), a dict of the same schema
    (``docs/behaviours.md``) or ``None`` (no actuation: zero joint torques). ``t_final`` (s)
    and ``stop_at="apex"`` (stop at the first apex of a flight); ``contacts``: the contacts
    active at the start (``"foot"``, ``"foot:slide"``); ``solve``: coordinates to solve so that
    they touch exactly; ``params``: values set by name before the run (``{"kp_push": 50,
    "legs.leg.links[1].length_m": 0.25}``); ``controller``: a Python callable instead of the
    behaviour (see the module documentation); ``**options``: any field of the Rust
    ``SimOptions`` (``rtol``, ``atol``, ``h_max_s``, ``event_tol_s``, ``delta_t_s``,
    ``zeno_window_s``, ``zeno_max_events``, ``max_events``, ``labels``, ``word``,
    ``stiff_switch``, ``velocity_tolerance``, ``truncate_unresolved_flights``).

    Bad input raises :class:`selfmanip.errors.InvalidInputError` (a ``ValueError``) or
    :class:`~selfmanip.errors.InvalidTypeError` (a ``TypeError``) whose ``field`` names it
    (``behaviour.joints[0].joint``, ``initial.q``, ``options.rtol``); a missing file
    ``FileNotFoundError``.

    ``sensitivity=True`` also computes the execution's derivatives to its initial state (the
    engine's variational equations and saltation matrices, ``docs/periodic-orbits.md``):
    ``Execution.state_jacobian`` and, on every event, ``saltation`` (an ``(n, n)`` array over
    ``(q, qd)``, ``None`` where undefined), ``saltation_status``, ``saltation_reason`` and
    ``time_gradient``. A behaviour with a ``joint_angle`` level, or a ``motor`` torque with
    ``reverse_beyond_rad``, has no partial derivatives yet:
    :class:`~selfmanip.errors.InvalidInputError` naming ``behaviour``; so does a Python
    ``controller``.

    ``parameters=["kp_push", ...]`` (with ``sensitivity=True``): also the final state's exact
    derivatives with respect to those parameters, named as in ``params=`` — a behaviour
    parameter (``kp_push``), any number of the behaviour by path
    (``joints[1].phases[0].torque.kp_n_m_per_rad``, a literal or a formula), the body's
    ``body.mass_kg`` and ``body.inertia_kg_m2``, a link's ``legs[0].links[1].mass_kg``,
    ``.inertia_kg_m2``, ``.com_m[0]``, ``.com_m[1]`` and a joint's ``.armature_kg_m2``, a
    contact's ``friction.mu`` and ``friction.mu_kinetic`` (``docs/sensitivity.md``)
    —: ``Execution.parameter_jacobian`` (``2 nq x len(parameters)``, ``None`` with
    ``parameter_reason`` where not formed) and each event's ``parameter_time_gradient``. A
    path without an exact derivative yet (a link's length, the terrain, a link mass or inertia
    of 0) has a NaN column and its reason in ``Execution.parameter_not_differentiated``
    (never a finite difference). A name that names nothing raises
    :class:`~selfmanip.errors.InvalidInputError` naming ``parameters[i]``.
    """
    if controller is not None and behaviour is not None:
        raise InvalidInputError("give a behaviour or a controller, not both", "controller")
    if not isinstance(sensitivity, bool):
        raise InvalidTypeError(f"`sensitivity` must be True or False, got {type(sensitivity).__name__}",
                               "sensitivity")
    names = _parameter_names(parameters, sensitivity)
    s = scenario(robot, behaviour, q0, qd0, terrain, t_final, stop_at, contacts=contacts, solve=solve,
                 params=params, **options)
    return Execution(s.run(controller), _robot(robot)[1], sensitivity, names)


def _parameter_names(parameters: Sequence[str] | None, sensitivity: bool) -> list[str]:
    """The parameter names or paths of ``simulate(..., parameters=...)``, checked."""
    if parameters is None:
        return []
    if isinstance(parameters, str) or not all(isinstance(p, str) for p in parameters):
        raise InvalidTypeError("`parameters` must be a list of parameter names or paths", "parameters")
    if not sensitivity:
        raise InvalidInputError("`parameters` needs `sensitivity=True`", "parameters")
    return list(parameters)


@dataclass(frozen=True)
class PeriodicOrbit:
    """A periodic orbit through the apex section (:func:`periodic_orbit`).

    ``x`` the fixed point ``(q, qd)`` at the apex (``qd`` of ``z`` zero), ``state_names`` its
    coordinates; ``period_s``; ``cyclic`` the coordinates left free (default ``["x"]``) and
    their ``drift`` per period (a stride); ``events`` of one period (``kind``, ``mode_after``;
    the apex last); ``monodromy`` the Jacobian ``DP`` of the apex-to-apex map over the whole
    state, whose ``multipliers`` include a trivial 0 (the section's direction: the flow);
    ``period_monodromy`` the Jacobian of the time-``T`` flow map, ``DP - f grad(tau)``, whose
    multipliers are the same with a trivial 1 instead; ``section_coordinates`` (every state
    coordinate but ``zdot`` and the cyclic ones), ``section_jacobian`` and
    ``section_multipliers`` (the nontrivial ones, by decreasing modulus); ``stability``
    (``stable``: all inside the unit circle; ``unstable``: one outside; ``neutral``: the
    largest on it); ``iterations``, ``residual`` (``|P(x) - x|`` at the end),
    ``rank_deficiency`` (directions along which the orbit is one of a family, e.g. a
    conserved momentum); ``one_sided``: the events at which several guards fire at once and
    the derivative depends on their order (``t_s``, ``kind``, ``guards`` and ``orders`` by
    contact name), where the monodromies are those of the first orders (the derivative on
    perturbations that keep the guards simultaneous, e.g. a symmetric pronk's symmetric
    ones; ``docs/periodic-orbits.md``, "Several guards at once")."""

    x: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    state_names: list[str]
    period_s: float
    cyclic: list[str]
    drift: np.ndarray
    events: list[dict[str, str]]
    monodromy: np.ndarray
    period_monodromy: np.ndarray
    multipliers: np.ndarray
    section_coordinates: list[str]
    section_jacobian: np.ndarray
    section_multipliers: np.ndarray
    stability: str
    iterations: int
    residual: float
    rank_deficiency: int
    one_sided: list[dict[str, Any]] = dataclass_field(default_factory=list)

    @property
    def stable(self) -> bool:
        return self.stability == "stable"


_PERIODIC_REALS = ("tol", "rank_rtol", "unit_circle_tol", "max_period_s", "rtol", "atol", "event_tol_s",
                   "delta_t_s")
_PERIODIC_INTS = ("max_iterations", "max_halvings", "max_runs")


def periodic_orbit(robot: RobotLike, behaviour: BehaviourLike, guess_q0: Sequence[float],
                   guess_qd0: Sequence[float] | None = None, section: str = "apex", terrain: TerrainLike = None,
                   *, cyclic: Sequence[str] | str | None | _Default = DEFAULT,
                   params: Mapping[str, Any] | None = None, **options: Any) -> PeriodicOrbit:
    """The periodic orbit of ``robot`` under ``behaviour`` through the apex section (the body's
    centre stops rising in flight), near the guess ``(guess_q0, guess_qd0)`` (in flight; its
    ``z`` rate is ignored: the section fixes it), found by damped Newton shooting on the
    engine's derivatives of the apex-to-apex return map (``docs/periodic-orbits.md``).

    ``section``: only ``"apex"`` for now. ``cyclic``: coordinates the dynamics do not depend
    on, left out of the fixed-point condition (default ``["x"]``, right on flat ground; ``[]``
    on a terrain that changes along ``x``). ``params``: values set by name first (as in
    :func:`simulate`). ``**options``: ``tol`` (``|P(x) - x|`` at convergence, SI units),
    ``max_iterations``, ``max_halvings`` (line-search halvings per iteration), ``max_runs``
    (return runs of the whole search: what bounds its cost), ``rank_rtol``,
    ``unit_circle_tol``, ``max_period_s`` (a return run longer than this fails), ``rtol``,
    ``atol``, ``event_tol_s``, ``delta_t_s``; every one left out keeps the Rust default.

    The behaviour must be autonomous (laws of the state and of the phase its contact events
    select: no ``at_s`` or ``delay_s`` clocks, no motion from ``theta`` or ``q0``), or the
    map of one hop is not that of the next; and it must have partial derivatives (no
    ``motor`` torque, no ``joint_angle`` level).

    Bad input raises :class:`~selfmanip.errors.InvalidInputError` /
    :class:`~selfmanip.errors.InvalidTypeError` naming the field; a search that does not
    converge, or a run that does not come back to the section, raises
    :class:`~selfmanip.errors.EngineError` with the reason.
    """
    if section != "apex":
        raise InvalidInputError(f"`section`: only \"apex\" is supported, got {section!r}", "section")
    opts: dict[str, Any] = {}
    for k, v in options.items():
        if k in _PERIODIC_REALS:
            opts[k] = _checks.real(k, v)
        elif k in _PERIODIC_INTS:
            opts[k] = _checks.integer(k, v, 0)
        else:
            raise InvalidInputError(f"unknown option `{k}` (options: {', '.join(_PERIODIC_REALS + _PERIODIC_INTS)})",
                                    k)
    if cyclic is not DEFAULT:
        opts["cyclic"] = _names("cyclic", cyclic) or []
    s = scenario(robot, behaviour, guess_q0, guess_qd0, terrain, params=params)
    d = s.periodic_orbit(opts)
    return PeriodicOrbit(
        x=d["x"], q=d["q"], qd=d["qd"], state_names=list(d["state_names"]), period_s=float(d["period_s"]),
        cyclic=list(d["cyclic"]), drift=d["drift"], events=[dict(e) for e in d["events"]],
        monodromy=d["monodromy"], period_monodromy=d["period_monodromy"], multipliers=d["multipliers"],
        section_coordinates=list(d["section_coordinates"]), section_jacobian=d["section_jacobian"],
        section_multipliers=d["section_multipliers"], stability=str(d["stability"]),
        iterations=int(d["iterations"]), residual=float(d["residual"]),
        rank_deficiency=int(d["rank_deficiency"]), one_sided=[dict(e) for e in d["one_sided"]])


def settable_names(robot: RobotLike, behaviour: BehaviourLike, q0: Sequence[float], **kwargs: Any) -> list[str]:
    """Every name :func:`sweep` and ``simulate(params=...)`` accept for this robot and
    behaviour: the behaviour's parameters, then every field's full path."""
    return list(scenario(robot, behaviour, q0, **kwargs).settable_names())


def simulation_sweep(robot: RobotLike, behaviour: BehaviourLike = None,
                     over: Mapping[str, Any] | Iterable[tuple[str, Any]] | None = None, *,
                     q0: Sequence[float], qd0: Sequence[float] | None = None, terrain: TerrainLike = None,
                     t_final: float | _Default = DEFAULT, stop_at: str | None | _Default = DEFAULT,
                     threads: int | None = None, progress: bool | Callable[[int], None] = False,
                     contacts: Sequence[str] | str | None = None, solve: Sequence[str] | str | None = None,
                     params: Mapping[str, Any] | None = None, **options: Any) -> dict[str, np.ndarray]:
    """The sweep of :func:`sweep` for any robot (arguments as in :func:`simulate`).

    ``over``: ``{name: values}`` — each a scalar or a 1-D array, combined as a grid (the last
    name varying fastest). Returns a dict of equal-length columns (``pandas.DataFrame(r)``
    works): the swept values, ``status`` (``final_time``/``apex``, an engine stop such as
    ``zeno``, or the error kind of a point that could not run: ``invalid_value``,
    ``unknown_reference``, …), ``error`` (its message; empty for a run), ``word``,
    ``mode_end``, ``n_events``, ``t_end_s``, ``flight_time_s``, ``impact_loss_j``,
    ``apex_{t_s,x_m,z_m,phi_rad,xdot_m_s,zdot_m_s,phidot_rad_s}``, ``landing_…`` (the body just
    before the first landing; z up: ``apex_z_m`` is the height above the ground, as in the
    leap sweep) and ``landing_energy_loss_j`` (NaN where there is none), and
    ``end_<coordinate>`` for every coordinate of ``q`` (as ``q`` has it: z down). A failing point never loses the
    others; the columns are bit-identical for any ``threads``; a name that names nothing
    raises :class:`~selfmanip.errors.InvalidInputError` before anything runs. When no point
    reaches its end an :class:`~selfmanip.errors.AllPointsFailedWarning` says so.
    """
    threads = _facade.threads(threads)
    items = list(over.items()) if isinstance(over, Mapping) else list(over or [])
    axes: list[tuple[str, list[Any]]] = []
    for name, values in items:
        if not isinstance(name, str):
            raise InvalidTypeError(f"`over`: names must be strings, got {name!r}", "over")
        if isinstance(values, (str, bytes, numbers.Number, Mapping)) or values is None:
            vals = [values]
        else:
            vals = list(np.asarray(values, dtype=object).ravel()) if isinstance(values, np.ndarray) else list(values)
        if not vals:
            raise InvalidInputError(f"`over[{name!r}]`: no values", name)
        axes.append((name, [_plain(name, v) for v in vals]))
    s = scenario(robot, behaviour, q0, qd0, terrain, t_final, stop_at, contacts=contacts, solve=solve,
                 params=params, **options)
    n = math.prod(len(v) for _, v in axes) if axes else 1
    part = s.sweep(axes, threads, _facade.progress(progress, n))
    out: dict[str, np.ndarray] = {}
    for name, _ in axes:
        out[name] = _facade.column(list(part[name]))
    for k, v in part.items():
        if k in out:
            continue
        out[k] = np.asarray(v, dtype=str) if isinstance(v, list) else np.asarray(v)
    _facade.warn_if_all_failed(out, stacklevel=2)
    return out


#: Arguments only a robot's sweep has, and only the RHex leap preset's.
_ROBOT_ARGUMENTS = ("robot", "behaviour", "over", "q0", "qd0", "t_final", "stop_at", "contacts", "solve")
_LEAP_ARGUMENTS = ("strategy", "t2", "gear_ratio", "actuator", "grid", "config", "sensitivities")


def sweep_kind(args: Sequence[Any], kwargs: Mapping[str, Any]) -> str:
    """Which sweep :func:`sweep` runs for these arguments, by the rule it documents:
    ``"robot"`` or ``"leap"``; arguments that fit neither, or that mix the two, raise
    :class:`~selfmanip.errors.InvalidTypeError` / :class:`~selfmanip.errors.InvalidInputError`
    naming the argument."""
    if args:
        first, field = args[0], "args[0]"
    elif "robot" in kwargs:
        first, field = kwargs["robot"], "robot"
    else:
        first, field = kwargs.get("strategy", "++"), "strategy"
    if isinstance(first, str):
        # a file name has an extension or a folder; a strategy ("++", "(+, -)") neither
        kind = "robot" if os.path.splitext(first)[1] or os.sep in first else "leap"
    elif isinstance(first, (Robot, os.PathLike, Mapping)):
        kind = "robot"
    elif isinstance(first, (list, tuple, np.ndarray)):
        kind = "leap"
    else:
        raise InvalidTypeError(
            f"`{field}`: sweep takes a strategy (\"++\", or a list of strategies) for the RHex leap, or a "
            f"robot (a selfmanip.Robot, a description file or dict) for any robot; got {type(first).__name__}",
            field)
    if field == "robot" and kind == "leap":
        raise InvalidTypeError(f"`robot`: a robot is a selfmanip.Robot, a description file or dict, got {first!r}",
                               "robot")
    other = _LEAP_ARGUMENTS if kind == "robot" else _ROBOT_ARGUMENTS
    for name in other:
        if name in kwargs:
            what = "the RHex leap preset's" if kind == "robot" else "a robot's sweep's"
            chosen = (f"the first argument {first!r} selects" if args or field in kwargs
                      else "without a robot first, sweep runs")
            raise InvalidInputError(f"`{name}` is {what} argument, but {chosen} the "
                                    f"{'robot' if kind == 'robot' else 'RHex leap'} sweep", name)
    return kind


@overload
def sweep(robot: RobotLike, behaviour: BehaviourLike = None,
          over: Mapping[str, Any] | Iterable[tuple[str, Any]] | None = None, *, q0: Sequence[float],
          qd0: Sequence[float] | None = None, terrain: TerrainLike = None, t_final: float | _Default = DEFAULT,
          stop_at: str | None | _Default = DEFAULT, threads: int | None = None,
          progress: bool | Callable[[int], None] = False, contacts: Sequence[str] | str | None = None,
          solve: Sequence[str] | str | None = None, params: Mapping[str, Any] | None = None,
          **options: Any) -> dict[str, np.ndarray]: ...


@overload
def sweep(strategy: str | Iterable[str] = "++", t2: Any = 0.0, gear_ratio: Any = DEFAULT,
          params: Mapping[str, Any] | None = None, threads: int | None = None,
          progress: bool | Callable[[int], None] = False, *, actuator: Any = DEFAULT, grid: bool = True,
          config: Mapping[str, Any] | None = None, sensitivities: Iterable[str] | None = None,
          **swept: Any) -> dict[str, np.ndarray]: ...


def sweep(*args: Any, **kwargs: Any) -> dict[str, np.ndarray]:
    """Sweeps: for any robot, or the RHex leap preset — chosen by the first argument (or
    ``robot=`` / ``strategy=``), by this rule:

    * a :class:`selfmanip.Robot`, a description dict, a path (``os.PathLike``, or a string
      with a file extension or a folder: ``"bounder.toml"``), or ``robot=``: any robot's
      sweep, :func:`simulation_sweep` (``sweep(robot, behaviour, over={...}, q0=...)``);
    * any other string, a list, tuple or array (strategies: ``"++"``, ``"(+, -)"``,
      ``["++", "--"]``), or no first argument at all: the RHex leap sweep,
      :func:`selfmanip.leap.sweep` (``sweep("++", t2=..., actuator=...)``), which refuses an
      unknown strategy naming ``strategy``;
    * anything else: :class:`~selfmanip.errors.InvalidTypeError` naming the argument. An
      argument of the other sweep (``over=`` after a strategy, ``t2=`` after a robot) is an
      :class:`~selfmanip.errors.InvalidInputError` naming it.

    Both return a dict of equal-length numpy arrays; the columns both have are typed alike:
    ``status`` and ``error`` (strings; :data:`COMPLETE_STATUSES` count as done), ``word``
    (cells joined by ``-``), ``n_events`` (int64) and ``apex_*`` (floats, NaN without an
    apex). ``apex_*`` and ``landing_*`` are z **up** in both: ``apex_z_m`` is the body
    centre's height above the ground (the world's z = 0) and ``apex_zdot_m_s`` its rate up;
    times and ``apex_x_m`` are the leap's from its front motor's start and its body's start,
    a robot's sweep's on the run's clock and in the world's x. Both
    take ``threads`` (default: every CPU this process may use) and ``progress``, and warn
    with :class:`~selfmanip.errors.AllPointsFailedWarning` when no point reaches its end.

    >>> import selfmanip
    >>> r = selfmanip.sweep(["++", "--"], t2=[0.0, 0.05], gear_ratio=[20.0, 28.0], threads=2)
    >>> r["strategy"][:4].tolist(), r["gear_ratio"][:4].tolist(), r["t2_s"][:2].tolist()
    (['++', '++', '++', '++'], [20.0, 20.0, 28.0, 28.0], [0.0, 0.05])
    """
    if sweep_kind(args, kwargs) == "robot":
        return simulation_sweep(*args, **kwargs)
    from . import leap as _leap

    return _leap.sweep(*args, **kwargs)
