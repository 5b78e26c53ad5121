"""The typed actuator of the RHex leap (``selfmanip.Saturated()``, ``selfmanip.GearedMotor(...)``)
and the one sweep façade (issue 29).

The independent route for the typed actuator's numbers is the ``gear_ratio=`` keyword it
replaces, which reaches the engine by a different encoding: the same leaps, compared bit for
bit. A sweep over several actuators is compared point by point with sweeps of one actuator
each (the regrouping of points into binding calls must not change a point or its place)."""

from __future__ import annotations

import dataclasses
import pathlib
import warnings

import numpy as np
import pytest

import selfmanip
from selfmanip import GearedMotor, Saturated
from selfmanip.errors import AllPointsFailedWarning
from selfmanip.leap import sweep_points

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "crates" / "selfmanip-sim" / "examples" / "data"
HOP_Q0 = [0.5, -1.0, 0.0, -0.451, 0.0]
T2 = [-0.05, 0.0, 0.05]


def bits(x):
    """A value as bytes: floats by their bits (NaN payloads included), arrays by dtype too."""
    a = np.asarray(x)
    return a.dtype.str, a.shape, a.tobytes() if a.dtype.kind != "O" else repr(a.tolist())


def same_leap(a, b):
    assert (a.status, a.word, a.reason) == (b.status, b.word, b.reason)
    assert (a.apex is None) == (b.apex is None)
    if a.apex is not None:
        assert bits(list(dataclasses.astuple(a.apex))) == bits(list(dataclasses.astuple(b.apex)))
    assert bits([e["t_s"] for e in a.events]) == bits([e["t_s"] for e in b.events])
    assert a.config == b.config and a.params == b.params
    for f in ("t_s", "q", "qd", "contact_forces_n"):
        assert bits(getattr(a.trajectory, f)) == bits(getattr(b.trajectory, f)), f


def same_table(a, b, rows=slice(None)):
    """``b``'s columns are ``a``'s rows ``rows``, bit for bit (strings by value: a table's
    string width is its longest entry's)."""
    for k in b:
        x, y = np.asarray(a[k])[rows], np.asarray(b[k])
        if x.dtype.kind == "U":
            assert y.dtype.kind == "U" and x.tolist() == y.tolist(), k
        else:
            assert bits(x) == bits(y), k


# ------------------------------------------------------------------ the same leaps as the keyword


@pytest.mark.parametrize("typed, keyword", [
    (dict(actuator=GearedMotor(ratio=28.0)), dict(gear_ratio=28.0)),
    (dict(actuator=GearedMotor(ratio=20.0, current_limit_a=15.0)), dict(gear_ratio=20.0, current_limit_a=15.0)),
    (dict(actuator=GearedMotor(ratio=35.0, motors_per_leg=1)), dict(gear_ratio=35.0, motors_per_leg=1)),
    (dict(actuator=Saturated()), dict(gear_ratio=None)),
])
def test_a_typed_actuator_gives_the_keywords_leap_bit_for_bit(typed, keyword):
    a = selfmanip.leap("++", 0.03, dt=0.005, **typed)
    b = selfmanip.leap("++", 0.03, dt=0.005, **keyword)
    same_leap(a, b)
    assert a.apex is not None
    assert a.actuator == typed["actuator"] == b.actuator
    assert a.gear_ratio == keyword["gear_ratio"] == b.gear_ratio


def test_a_typed_actuator_gives_the_keywords_sensitivities_bit_for_bit():
    a = selfmanip.leap("++", 0.025, actuator=GearedMotor(), dt=None, sensitivities=["t2", "gear_ratio"])
    b = selfmanip.leap("++", 0.025, 28.0, dt=None, sensitivities=["t2", "gear_ratio"])
    assert a.sensitivity_ok == b.sensitivity_ok
    assert bits(list(a.sensitivity.values())) == bits(list(b.sensitivity.values()))


def test_a_typed_sweep_gives_the_keywords_table_bit_for_bit():
    typed = selfmanip.sweep(["++", "-+"], t2=T2, actuator=[Saturated(), GearedMotor(ratio=22.0)], threads=2)
    keyword = selfmanip.sweep(["++", "-+"], t2=T2, gear_ratio=[None, 22.0], threads=2)
    assert list(typed) == list(keyword)
    same_table(typed, keyword)


def test_the_default_geared_motor_is_the_engines_default_actuator():
    default = selfmanip.leap.defaults()["config"]["actuator"]
    assert default["kind"] == "geared_motor"
    motor = GearedMotor()
    assert (motor.ratio, motor.current_limit_a, motor.motors_per_leg) == (
        default["gear_ratio"], default["current_limit_a"], default["motors_per_leg"])
    same_leap(selfmanip.leap("--", -0.02, dt=0.005), selfmanip.leap("--", -0.02, dt=0.005, actuator=motor))


def test_a_sweep_of_actuators_that_differ_in_their_motors_keeps_each_point_and_its_place():
    """Geared motors with different current limits run in separate binding calls; the table
    is in input order and each row is the row of a sweep of that actuator alone."""
    actuators = [GearedMotor(ratio=20.0, current_limit_a=10.0), Saturated(), GearedMotor(ratio=28.0),
                 GearedMotor(ratio=28.0, motors_per_leg=1)]
    seen = []
    table = selfmanip.sweep(["++", "--"], t2=T2, actuator=actuators, threads=2, progress=seen.append)
    assert sorted(seen)[-1] == len(table["status"]) == 2 * len(actuators) * len(T2)
    got = list(zip(table["strategy"], table["current_limit_a"], table["motors_per_leg"], table["t2_s"]))
    fields = [(a.current_limit_a, a.motors_per_leg) if isinstance(a, GearedMotor) else (np.nan, np.nan)
              for a in actuators]
    want = [(s, *f, t) for s in ("++", "--") for f in fields for t in T2]
    assert bits(np.asarray([g[1:] for g in got], dtype=float)) == bits(np.asarray([w[1:] for w in want], dtype=float))
    assert [g[0] for g in got] == [w[0] for w in want]
    for s_i, s in enumerate(("++", "--")):
        for a_i, a in enumerate(actuators):
            alone = selfmanip.sweep(s, t2=T2, actuator=a, threads=1)
            start = (s_i * len(actuators) + a_i) * len(T2)
            same_table(table, alone, slice(start, start + len(T2)))


# ------------------------------------------------------------------ bad actuators name the field


@pytest.mark.parametrize("kwargs, error, field", [
    (dict(ratio=-3.0), selfmanip.InvalidInputError, "ratio"),
    (dict(ratio=float("inf")), selfmanip.InvalidInputError, "ratio"),
    (dict(ratio="28"), selfmanip.InvalidTypeError, "ratio"),
    (dict(current_limit_a=0.0), selfmanip.InvalidInputError, "current_limit_a"),
    (dict(current_limit_a=float("nan")), selfmanip.InvalidInputError, "current_limit_a"),
    (dict(current_limit_a=True), selfmanip.InvalidTypeError, "current_limit_a"),
    (dict(motors_per_leg=0), selfmanip.InvalidInputError, "motors_per_leg"),
    (dict(motors_per_leg=2**32), selfmanip.InvalidInputError, "motors_per_leg"),
    (dict(motors_per_leg=1.5), selfmanip.InvalidTypeError, "motors_per_leg"),
])
def test_a_bad_geared_motor_names_its_field(kwargs, error, field):
    with pytest.raises(error, match=field) as e:
        GearedMotor(**kwargs)
    assert e.value.field == field


@pytest.mark.parametrize("call, error, field", [
    (lambda: selfmanip.leap("++", 0.0, actuator=28.0), selfmanip.InvalidTypeError, "actuator"),
    (lambda: selfmanip.leap("++", 0.0, Saturated()), selfmanip.InvalidTypeError, "gear_ratio"),
    (lambda: selfmanip.leap("++", 0.0, 28.0, actuator=GearedMotor()), selfmanip.InvalidInputError, "gear_ratio"),
    (lambda: selfmanip.leap("++", 0.0, actuator=GearedMotor(), current_limit_a=9.0), selfmanip.InvalidInputError,
     "current_limit_a"),
    (lambda: selfmanip.leap("++", 0.0, actuator=Saturated(), motors_per_leg=1), selfmanip.InvalidInputError,
     "motors_per_leg"),
    (lambda: selfmanip.leap("++", 0.0, actuator=[Saturated(), GearedMotor()]), selfmanip.InvalidInputError,
     "actuator"),
    (lambda: selfmanip.sweep("++", t2=[0.0], actuator=[Saturated(), 28.0]), selfmanip.InvalidTypeError,
     "actuator[1]"),
    (lambda: selfmanip.sweep("++", t2=[0.0], actuator=[]), selfmanip.InvalidInputError, "actuator"),
    (lambda: selfmanip.sweep("++", t2=[0.0], gear_ratio=np.ones((2, 2))), selfmanip.InvalidInputError, "gear_ratio"),
    (lambda: selfmanip.sweep("++", t2=[0.0], actuator=[GearedMotor()], m_b=8.0, current_limit_a=[5.0, 9.0]),
     selfmanip.InvalidInputError, "current_limit_a"),
])
def test_a_bad_actuator_argument_names_it(call, error, field):
    with pytest.raises(error) as e:
        call()
    assert e.value.field == field


def test_an_axis_of_actuators_may_be_any_1d_sequence_and_a_0d_array_is_a_scalar():
    assert sweep_points("++", t2=0.0, gear_ratio=np.asarray(28.0))["actuator"] == [28.0]
    axis = np.asarray([Saturated(), GearedMotor()], dtype=object)
    assert sweep_points("++", t2=0.0, actuator=axis)["actuator"] == [Saturated(), GearedMotor()]
    assert sweep_points("++", t2=0.0, actuator=(GearedMotor(ratio=20.0),))["actuator"] == [GearedMotor(ratio=20.0)]


def test_the_actuator_classes_are_values():
    assert GearedMotor(ratio=28) == GearedMotor() and isinstance(GearedMotor(ratio=np.float64(28)).ratio, float)
    assert Saturated() == Saturated() and Saturated() != GearedMotor()
    assert {GearedMotor(), GearedMotor(ratio=28.0), Saturated()} == {GearedMotor(), Saturated()}
    with pytest.raises(dataclasses.FrozenInstanceError):
        GearedMotor().ratio = 3.0


def test_the_chapter3_job_takes_the_typed_actuator(tmp_path):
    from selfmanip import chapter3

    lines_a, lines_b = [], []
    a = chapter3.run(tmp_path / "a", n=3, saturated=True, threads=1, echo=lines_a.append)
    b = chapter3.run(tmp_path / "b", n=3, actuator=Saturated(), threads=1, echo=lines_b.append)
    same_table(a, b)
    assert lines_a[:-1] == lines_b[:-1] and "saturated torque" in lines_a[0]
    with pytest.raises(selfmanip.InvalidInputError) as e:
        chapter3.run(tmp_path / "c", n=3, saturated=True, actuator=Saturated())
    assert e.value.field == "saturated"
    with pytest.raises(selfmanip.InvalidTypeError) as e:
        chapter3.run(tmp_path / "c", n=3, actuator=28.0)
    assert e.value.field == "actuator"


# ------------------------------------------------------------------ one sweep, an explicit rule


@pytest.mark.parametrize("args, kwargs, error, field", [
    ((5,), dict(t2=[0.0]), selfmanip.InvalidTypeError, "args[0]"),
    ((None,), {}, selfmanip.InvalidTypeError, "args[0]"),
    ((), dict(robot=["++"]), selfmanip.InvalidTypeError, "robot"),
    (("++",), dict(over={"kp_push": [1.0]}), selfmanip.InvalidInputError, "over"),
    (("(+, -)",), dict(q0=HOP_Q0), selfmanip.InvalidInputError, "q0"),
    ((DATA / "hopper.toml", DATA / "hop.toml"), dict(t2=[0.0], q0=HOP_Q0), selfmanip.InvalidInputError, "t2"),
    ((str(DATA / "hopper.toml"), DATA / "hop.toml"), dict(actuator=Saturated(), q0=HOP_Q0),
     selfmanip.InvalidInputError, "actuator"),
    (("++",), dict(t2=[0.0], threads=0), selfmanip.InvalidInputError, "threads"),
    ((DATA / "hopper.toml", DATA / "hop.toml"), dict(over={"kp_push": [20.0]}, q0=HOP_Q0, threads="2"),
     selfmanip.InvalidTypeError, "threads"),
    (("++",), dict(t2=[0.0], progress="yes"), selfmanip.InvalidTypeError, "progress"),
])
def test_sweep_refuses_arguments_that_fit_neither_sweep_naming_them(args, kwargs, error, field):
    with pytest.raises(error) as e:
        selfmanip.sweep(*args, **kwargs)
    assert e.value.field == field


def test_sweep_dispatches_by_its_documented_rule():
    leap = selfmanip.sweep("(+, -)", t2=[0.0], threads=1)
    assert leap["strategy"].tolist() == ["+-"]
    assert selfmanip.sweep(np.asarray(["++", "--"]), t2=[0.0], threads=1)["strategy"].tolist() == ["++", "--"]
    assert selfmanip.sweep(strategy="--", t2=[0.0], threads=1)["strategy"].tolist() == ["--"]
    robot = selfmanip.sweep(str(DATA / "hopper.toml"), DATA / "hop.toml", over={"kp_push": [20.0]}, q0=HOP_Q0,
                            t_final=0.3, threads=1)
    assert robot["kp_push"].tolist() == [20.0]


def test_the_two_sweeps_share_their_common_columns_types():
    """Both return dicts of numpy arrays; the columns both have are typed alike, and the
    statuses that count as done are one list."""
    leap = selfmanip.sweep("++", t2=[0.0], threads=1)
    robot = selfmanip.sweep(DATA / "hopper.toml", DATA / "hop.toml", over={"kp_push": [45.0]}, q0=HOP_Q0,
                            stop_at="apex", threads=1)
    shared = set(leap) & set(robot)
    assert {"status", "error", "word", "n_events", "apex_t_s", "apex_x_m", "apex_z_m", "apex_phi_rad",
            "apex_xdot_m_s", "apex_zdot_m_s", "apex_phidot_rad_s"} <= shared
    for k in shared:
        assert np.asarray(leap[k]).dtype.kind == np.asarray(robot[k]).dtype.kind, k
    for table in (leap, robot):
        assert set(table["status"]) <= set(selfmanip.simulation.COMPLETE_STATUSES), table["status"]
        assert "-" in table["word"][0] and table["word"][0].split("-")[0]


def test_no_point_done_warns_alike_on_both_sweeps():
    for call in (lambda: selfmanip.sweep("++", t2=[0.0], m_b=-1.0, threads=1),
                 lambda: selfmanip.sweep(DATA / "hopper.toml", DATA / "hop.toml", over={"body.mass_kg": [-1.0]},
                                         q0=HOP_Q0, threads=1)):
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            table = call()
        assert [type(x.message) for x in w] == [AllPointsFailedWarning]
        assert str(w[0].message).startswith("all 1 points of the sweep failed") and table["error"][0]
