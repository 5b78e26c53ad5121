"""Every public object of the package round-trips through ``pickle`` and ``copy.deepcopy``
(issue 30, item 7), so that joblib, Ray, Dask and ``multiprocessing`` pools can carry them.

The classes are enumerated from the package (``selfmanip.__all__`` and every public
submodule), and each must have an example below: a class added without one fails
``test_every_public_class_has_an_example``. The independent route for "the copy is the same
object" is the object's own behaviour, compared bit for bit: a robot copy gives the same
dynamics at a state, an execution copy samples the same trajectory arrays and the same
energy report, a spatial robot copy the same mass matrix.
"""

from __future__ import annotations

import copy
import dataclasses
import importlib
import inspect
import pathlib
import pickle
import pkgutil

import numpy as np
import pytest

import selfmanip
from selfmanip import plots
from selfmanip.calibrate import LeapModel, read_table

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "crates" / "selfmanip-sim" / "examples" / "data"
URDF = ROOT / "tests" / "data" / "urdf" / "quadruped12.urdf"
HOP_Q0 = [0.5, -1.0, 0.0, -0.451, 0.0]

LINK = {"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4}


def bounder() -> dict:
    """The newcomer's two-legged bounder of issue 30's appendix."""
    def foot(g):
        return {"name": f"{g}_foot", "leg": g, "shape": {"kind": "point", "position_m": [0, 0.15]},
                "friction": {"kind": "sticking", "mu": 0.8}}

    return {"name": "bounder", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
            "contacts": [foot("front"), foot("hind")],
            "legs": [{"name": n, "hip_m": [x, 0.0], "links": [dict(LINK), dict(LINK)]}
                     for n, x in (("front", 0.2), ("hind", -0.2))]}


def planted_state(robot: selfmanip.Robot) -> tuple[list[float], list[float]]:
    q = [0.3, -0.6, 0.2, -0.5, 0.0, -0.3, 0.05]
    return q, [0.1 * (i + 1) for i in range(robot.nq)]


def controller(t, q, qd, mode):
    """A module-level (so picklable) controller: a PD law on the hopper's joints."""
    return [-5.0 * (q[0] - 0.5) - 0.1 * qd[0], -5.0 * (q[1] + 1.0) - 0.1 * qd[1]]


def _leap():
    return selfmanip.leap("++", t2=0.01)


def _robot():
    return selfmanip.Robot.from_dict(bounder())


def _execution():
    return selfmanip.simulate(DATA / "hopper.toml", DATA / "hop.toml", HOP_Q0, t_final=0.3)


def _spatial():
    feet = ("FL_foot", "FR_foot", "HL_foot", "HR_foot")
    return selfmanip.SpatialRobot.from_urdf(URDF, contacts={f: {"friction": 0.8} for f in feet})


def _spatial_dynamics():
    r = _spatial()
    return r.dynamics(["FL_foot", "FR_foot"], r.neutral(), np.zeros(r.nv), np.zeros(r.nv))


def _spatial_impact():
    r = _spatial()
    return r.impact(["FL_foot", "FR_foot"], r.neutral(), np.linspace(-0.1, 0.1, r.nv))


def _spatial_kkt():
    r = _spatial()
    return r.kkt("1111", r.neutral())


def _spatial_quasi_static():
    r = _spatial()
    return r.quasi_static(["FL_foot", "FR_foot", "HL_foot", "HR_foot"], r.neutral())


def _periodic_orbit():
    return selfmanip.periodic_orbit(DATA / "hopper.toml", DATA / "hop_periodic.toml", [0.5, -1.0, 0.0, -0.45, 0.0])


def _robot_call(name):
    def make():
        r = _robot()
        q, qd = planted_state(r)
        return {
            "ContactPoints": lambda: r.contact_points(q, qd),
            "Dynamics": lambda: r.dynamics("front_foot,hind_foot", q, qd, [0.1, 0.2, 0.3, 0.4]),
            "Impact": lambda: r.impact("front_foot,hind_foot", q, qd),
            "Kinematics": lambda: r.forward_kinematics(q, qd),
            "KktBlocks": lambda: r.kkt("front_foot,hind_foot", q),
            "PointJacobian": lambda: r.jacobian(q, "front_0", (0.0, 0.15)),
            "QuasiStatic": lambda: selfmanip.rhex.Model().quasi_static("0101", [0.3, 0.3, 0, -0.162, 0], [[1.0, -1.0]]),
        }[name]()

    return make


def _error(cls):
    if cls is selfmanip.errors.SingularKktError:
        return lambda: cls("singular", "q", "RedundantConstraints", 1e17)
    if issubclass(cls, selfmanip.errors.SelfmanipError):
        return lambda: cls("a message", "a.field")
    return lambda: cls("a message")


#: One example per public class, by qualified name.
EXAMPLES = {
    "selfmanip.leap.LeapResult": _leap,
    "selfmanip.leap.Apex": lambda: _leap().apex,
    "selfmanip.leap.Trajectory": lambda: _leap().trajectory,
    "selfmanip.actuator.Saturated": selfmanip.Saturated,
    "selfmanip.actuator.GearedMotor": lambda: selfmanip.GearedMotor(ratio=31.5, current_limit_a=12.0, motors_per_leg=1),
    "selfmanip.rhex.Model": lambda: selfmanip.rhex.Model({"m_b": 7.5}),
    "selfmanip.rhex.ContactModeMap": lambda: selfmanip.rhex.Model().contact_mode_map(6),
    "selfmanip.robot.Robot": _robot,
    "selfmanip.simulation.Execution": _execution,
    "selfmanip.simulation.EnergyReport": lambda: _execution().energy_report(),
    "selfmanip.simulation.SimTrajectory": lambda: _execution().trajectory(0.01),
    "selfmanip.simulation.PeriodicOrbit": _periodic_orbit,
    "selfmanip.spatial.SpatialRobot": _spatial,
    "selfmanip.spatial.SpatialDynamics": _spatial_dynamics,
    "selfmanip.spatial.SpatialImpact": _spatial_impact,
    "selfmanip.spatial.SpatialQuasiStatic": _spatial_quasi_static,
    "selfmanip.spatial.SpatialKkt": _spatial_kkt,
    "selfmanip.calibrate.Calibration": lambda: selfmanip.calibrate(
        "leap", {"strategy": ["--"] * 2, "t2_s": [-0.03, 0.04], "apex_z_m": [0.52, 0.42]}, {"m_b": (5.0, 9.5)}),
    "selfmanip.calibrate.LeapModel": lambda: LeapModel({"mu_rear": 2.0}),
    "selfmanip.calibrate.MeasuredTable": lambda: read_table(
        {"strategy": ["++", "--"], "t2 [s]": [0.0, 0.1], "z [mm]": ["*", 412], "x [mm]": [300, 280]}),
    **{f"selfmanip.robot.{n}": _robot_call(n) for n in
       ("ContactPoints", "Dynamics", "Impact", "Kinematics", "KktBlocks", "PointJacobian", "QuasiStatic")},
}


def public_classes() -> dict[str, type]:
    """Every class the package offers: named in ``selfmanip.__all__`` or defined in a public
    submodule (its ``__all__`` when it has one, else its public names)."""
    found: dict[str, type] = {}

    def add(obj):
        if inspect.isclass(obj) and obj.__module__.startswith("selfmanip") and not obj.__name__.startswith("_"):
            found[f"{obj.__module__}.{obj.__qualname__}"] = obj

    for name in selfmanip.__all__:
        add(getattr(selfmanip, name))
    for info in pkgutil.iter_modules(selfmanip.__path__):
        if info.name.startswith("_") or info.name == "__main__":
            continue
        mod = importlib.import_module(f"selfmanip.{info.name}")
        names = getattr(mod, "__all__", None) or [n for n in vars(mod) if not n.startswith("_")]
        for n in names:
            obj = getattr(mod, n, None)
            if inspect.isclass(obj) and obj.__module__ == mod.__name__:
                add(obj)
    return found


def example(name: str, cls: type):
    if issubclass(cls, BaseException):
        return _error(cls)()
    return EXAMPLES[name]()


def same(a, b, where="") -> None:
    """``a`` and ``b`` are the same value bit for bit (floats by their bits, arrays by dtype,
    shape and bytes), recursively through dataclasses, dicts, lists and tuples."""
    assert type(a) is type(b), where
    if isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape, where
        if a.dtype.kind == "O":
            for i, (x, y) in enumerate(zip(a.ravel(), b.ravel())):
                same(x, y, f"{where}[{i}]")
        else:
            assert a.tobytes() == b.tobytes(), where
    elif dataclasses.is_dataclass(a):
        for f in dataclasses.fields(a):
            same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert list(a) == list(b), where
        for k in a:
            same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (list, tuple)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            same(x, y, f"{where}[{i}]")
    elif isinstance(a, float):
        assert np.float64(a).tobytes() == np.float64(b).tobytes(), where
    elif isinstance(a, BaseException):
        assert a.args == b.args and vars(a) == vars(b), where
    elif isinstance(a, (selfmanip.Robot, selfmanip.SpatialRobot, selfmanip.Execution)):
        same_behaviour(a, b, where)
    else:
        assert a == b, where


def same_behaviour(a, b, where) -> None:
    """The objects that wrap engine state: the same answers, bit for bit."""
    if isinstance(a, selfmanip.Robot):
        assert a.coordinate_names == b.coordinate_names and a.contact_names == b.contact_names, where
        if a._native.is_rhex:
            same(a.params, b.params, where)
            q, qd, mode, tau = [0.3, 0.3, 0.0, -0.162, 0.0], [0.1, -0.2, 0.3, 0.0, 0.1], "0101", [3.0, 3.0]
        else:
            same(a.to_dict(), b.to_dict(), where)
            (q, qd), mode, tau = planted_state(a), "front_foot,hind_foot", [0.1, 0.2, 0.3, 0.4]
        same(a.dynamics(mode, q, qd, tau), b.dynamics(mode, q, qd, tau), where)
        same(a.energy(q, qd), b.energy(q, qd), where)
    elif isinstance(a, selfmanip.SpatialRobot):
        assert a.frame_names == b.frame_names and a.contacts == b.contacts, where
        q = a.neutral()
        same(a.mass_matrix(q), b.mass_matrix(q), where)
        if a.contacts:
            same(a.kkt(None, q), b.kkt(None, q), where)
    else:
        for k in ("status", "reason", "word", "q_names", "labels", "outcome", "events", "segments",
                  "state_jacobian", "parameter_jacobian"):
            same(getattr(a, k), getattr(b, k), f"{where}.{k}")
        same(a.trajectory(0.001), b.trajectory(0.001), f"{where}.trajectory")
        same(a.energy_report(), b.energy_report(), f"{where}.energy_report")


CLASSES = public_classes()


def test_every_public_class_has_an_example() -> None:
    """A new public class fails here until it has an example (and so a round-trip test)."""
    missing = [n for n, c in CLASSES.items() if not issubclass(c, BaseException) and n not in EXAMPLES]
    assert not missing, f"public classes without a pickling example: {missing}"
    # the enumeration reaches the submodules, not only selfmanip.__all__
    assert {"selfmanip.rhex.Model", "selfmanip.spatial.SpatialDynamics", "selfmanip.plots.PlottingUnavailableError"} \
        <= set(CLASSES)


@pytest.mark.parametrize("name", sorted(CLASSES))
def test_round_trip(name: str) -> None:
    obj = example(name, CLASSES[name])
    assert isinstance(obj, CLASSES[name])
    for copied in (pickle.loads(pickle.dumps(obj)), copy.deepcopy(obj)):
        same(obj, copied, name)


def test_execution_replays_lazily_and_bit_for_bit() -> None:
    """An unpickled execution answers from its data at once and replays the engine run only
    when a method needs it; the replay is the same run (every sample's bits)."""
    e = selfmanip.simulate(DATA / "hopper.toml", DATA / "hop.toml", HOP_Q0, t_final=0.3, sensitivity=True)
    c = pickle.loads(pickle.dumps(e))
    assert c._native is None and c.status == e.status and c.word == e.word
    same(c.state_jacobian, e.state_jacobian)
    same(c.events, e.events)
    same(c.trajectory(0.0005), e.trajectory(0.0005))
    assert c._native is not None
    again = pickle.loads(pickle.dumps(c))        # a copy of a replayed copy
    same(again, e, "again")


def test_python_controller_run_round_trips() -> None:
    """A run driven by a picklable Python controller keeps it and replays with it."""
    e = selfmanip.simulate(DATA / "hopper.toml", None, HOP_Q0, t_final=0.2, controller=controller)
    same(pickle.loads(pickle.dumps(e)), e, "controller run")
    with pytest.raises((pickle.PicklingError, AttributeError)):
        pickle.dumps(selfmanip.simulate(DATA / "hopper.toml", None, HOP_Q0, t_final=0.05,
                                        controller=lambda t, q, qd, mode: [0.0, 0.0]))


def test_sweep_table_round_trips() -> None:
    table = selfmanip.sweep(DATA / "hopper.toml", DATA / "hop.toml", over={"kp_push": [40.0, 50.0]}, q0=HOP_Q0,
                            t_final=0.3, threads=1)
    same(pickle.loads(pickle.dumps(table)), table)


def test_rhex_model_copy_keeps_its_parameters() -> None:
    """The copy of a model built from non-default parameters is that model, not the default
    one (its parameters and its dynamics differ from the default's)."""
    m = selfmanip.rhex.Model({"m_b": 7.5})
    c = pickle.loads(pickle.dumps(m))
    assert c.params["m_b"] == 7.5 != selfmanip.rhex.Model().params["m_b"]
    assert type(c) is type(m)


def test_plotting_unavailable_error_is_an_import_error() -> None:
    assert issubclass(plots.PlottingUnavailableError, ImportError)
    assert issubclass(plots.PlottingUnavailableError, selfmanip.SelfmanipError)
