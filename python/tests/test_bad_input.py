"""Bad input: typed Python errors that name the offending field, never a crash."""

import math
import re

import pytest

import selfmanip
from selfmanip import _native, motor
from selfmanip import (EngineError, IllPosedError, InvalidInputError, InvalidTypeError, SelfmanipError,
                       SingularKktError)

Q = [0.3, 0.3, 0.0, -0.17 * math.cos(0.3), 0.0]


def test_error_hierarchy_has_one_base_and_builtin_semantics():
    # input errors are ValueError / TypeError, engine failures RuntimeError, all SelfmanipError
    for cls, builtin in ((InvalidInputError, ValueError), (InvalidTypeError, TypeError),
                         (SingularKktError, ValueError), (IllPosedError, ValueError), (EngineError, RuntimeError)):
        assert issubclass(cls, SelfmanipError) and issubclass(cls, builtin), cls
    assert not issubclass(EngineError, ValueError)
    assert not issubclass(SelfmanipError, ValueError)


@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_state(rhex, bad):
    q = list(Q)
    q[3] = bad
    with pytest.raises(ValueError, match="`q`.*index 3"):
        rhex.dynamics("0101", q, [0.0] * 5, [0.0, 0.0])
    with pytest.raises(ValueError, match="`tau`"):
        rhex.dynamics("0101", Q, [0.0] * 5, [bad, 0.0])


def test_wrong_lengths(rhex):
    with pytest.raises(ValueError, match="`qd` has length 4, expected 5"):
        rhex.dynamics("0101", Q, [0.0] * 4, [0.0, 0.0])
    with pytest.raises(ValueError, match="`tau` has length 3"):
        rhex.dynamics("0101", Q, [0.0] * 5, [0.0] * 3)
    with pytest.raises(ValueError, match="1-D"):
        rhex.dynamics("0101", [Q], [0.0] * 5, [0.0] * 2)


def test_wrong_types(rhex):
    with pytest.raises(TypeError, match="`q`"):
        rhex.dynamics("0101", "0.1,0.2", [0.0] * 5, [0.0, 0.0])
    with pytest.raises(TypeError, match="`mode`"):
        rhex.dynamics(101, Q, [0.0] * 5, [0.0, 0.0])
    with pytest.raises(TypeError, match="`m_b`"):
        selfmanip.rhex.Model({"m_b": "heavy"})
    with pytest.raises(TypeError, match="`m_b`"):
        selfmanip.rhex.Model({"m_b": True})


@pytest.mark.parametrize(
    "params, field",
    [({"m_b": -1.0}, "m_b"), ({"rho1": 0.0}, "rho1"), ({"I_l": math.nan}, "I_l"), ({"pairs": []}, "pairs"),
     ({"mu_rear": -0.5}, "mu_rear"), ({"leg_shape": "square"}, "leg_shape"), ({"legs": 3}, "legs")],
)
def test_bad_parameters(params, field):
    with pytest.raises(ValueError, match=field):
        selfmanip.rhex.Model(params)


@pytest.mark.parametrize("label", ["010", "01010", "01x1", "s101", ""])
def test_bad_mode_labels(rhex, label):
    with pytest.raises(ValueError, match="label"):
        rhex.dynamics(label, Q, [0.0] * 5, [0.0, 0.0])


def test_singular_contact_set_reports_condition(rhex):
    """1111 over-constrains the planar body (Lemma 5.1): a typed error with a condition estimate."""
    with pytest.raises(SingularKktError, match="RedundantConstraints.*condition estimate"):
        rhex.dynamics("1111", Q, [0.0] * 5, [0.0, 0.0])


def test_bad_description(tmp_path, quadruped):
    text = (tmp_path / "x.toml")
    src = open(__import__("conftest").QUADRUPED, encoding="utf-8").read()
    text.write_text(src.replace("mass_kg = 12.0", "mass_kg = -12.0"))
    with pytest.raises(ValueError, match="mass"):
        selfmanip.Robot.from_file(text)
    with pytest.raises(ValueError, match="parse"):
        selfmanip.Robot.from_toml("this is [not toml")
    with pytest.raises(ValueError, match="unknown contact"):
        quadruped.dynamics("fore_foot,tail", [0.0] * 7, [0.0] * 7, [0.0] * 4)
    with pytest.raises(FileNotFoundError):
        selfmanip.Robot.from_file(tmp_path / "missing.toml")


@pytest.mark.parametrize("call, message", [
    (lambda: _native.analysis_takeoff_speed(None, "wheel", 0.0, 0.0, 0.0, 28.0),
     '`leg` must be "stick", "half_circle" or "rolling", got "wheel"'),
    (lambda: _native.analysis_standing_rhex(None, "square", 0, 0.1, 3.0, 1e-3, 1),
     '`leg_shape` must be "stick" or "half_circle", got "square"'),
    (lambda: motor.operating_point("x-rhex-28", 1.0, 0.0, gearbox_loss="lossy"),
     '`gearbox_loss` must be "derating" or "power_flow", got "lossy"'),
    (lambda: motor.thermal_simulation("x-rhex-18", [1.0], case="hot"),
     '`case` must be "measured" or "listed", got "hot"'),
])
def test_a_name_outside_its_choices_lists_them(call, message):
    # the native layer's own check (the Python layer checks `leg` before it gets there)
    with pytest.raises(InvalidInputError, match=re.escape(message)) as e:
        call()
    assert e.value.field == message[1:message.index("`", 1)]
