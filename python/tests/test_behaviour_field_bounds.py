"""A user's behaviour whose motion has a speed or an acceleration the free joints' tracking law
cannot difference (above ``f64::MAX / 2``) is refused when it is compiled, with an
``InvalidInputError`` naming the field's path, not run into the engine's nameless non-finite
error. The robot is the example hopper (``hopper.toml``) under ``hop.toml``, whose motions read
the parameters ``swing_speed`` and ``swing_accel``."""

from __future__ import annotations

import math
import pathlib
import sys

import pytest

import selfmanip
from selfmanip.errors import InvalidInputError

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
HOPPER, HOP = DATA / "hopper.toml", DATA / "hop.toml"
Q0 = [0.5, -1.0, 0.0, -0.451, 0.0]
HALF_MAX = sys.float_info.max / 2


def run(params):
    return selfmanip.simulate(HOPPER, HOP, Q0, t_final=0.05, params=params)


@pytest.mark.parametrize("name, value, field", [
    ("swing_accel", sys.float_info.max, "joints[0].phases[0].motion.accel_rad_s2"),
    ("swing_speed", 1e308, "joints[0].phases[0].motion.speed_rad_s"),
])
def test_a_motion_number_above_half_the_largest_float_names_its_field(name, value, field):
    with pytest.raises(InvalidInputError) as e:
        run({name: value})
    assert e.value.field.endswith(field), str(e.value)
    assert "f64::MAX / 2" in str(e.value)


def test_the_bound_is_half_the_largest_float():
    # doubling f64::MAX / 2 stays finite; the next float above it overflows, and is refused
    above = math.nextafter(HALF_MAX, math.inf)
    assert HALF_MAX * 2 < math.inf and above * 2 == math.inf
    with pytest.raises(InvalidInputError) as e:
        run({"swing_accel": above})
    assert e.value.field.endswith("joints[0].phases[0].motion.accel_rad_s2")
    # at the bound the behaviour compiles: whatever the run then gives, not this refusal
    try:
        run({"swing_accel": HALF_MAX})
    except InvalidInputError as err:
        assert "f64::MAX / 2" not in str(err), str(err)
