"""The reproducers of issue 31 that crashed (unbounded recursion), hung (an eigenvalue
routine without an iteration cap), returned non-finite numbers or a wrong energy balance,
or accepted input they could not honour. Each now ends in a typed error naming the field, a
typed status, or a correct finite result; the bounds are the code's, not timings."""

from __future__ import annotations

import math
import pathlib

import pytest

import selfmanip
from selfmanip import cli_sim, leap as leap_mod
from selfmanip.errors import AllPointsFailedWarning, InvalidInputError, SelfmanipError

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
ROBOTS = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data" / "robots"
HOP, HOPB = DATA / "hopper.toml", DATA / "hop.toml"
Q0H = [0.5, -1.0, 0.0, -0.451, 0.0]


def knee_torque(formula_params: dict) -> dict:
    return {"parameters": formula_params,
            "joints": [{"joint": "leg[1]", "phases": [{"name": "a", "torque": {"kind": "constant", "torque_n_m": "p"}}]}]}


def test_ten_thousand_nested_parentheses_name_the_parameter():
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, knee_torque({"p": "(" * 10000 + "1" + ")" * 10000}), Q0H, t_final=0.01)
    assert e.value.field == "behaviour.parameters.p" or e.value.field.endswith("parameters.p")


def test_a_sum_of_a_hundred_thousand_terms_names_the_parameter_in_a_sweep():
    # each point fails alone in its worker thread (it overflowed the worker's stack)
    behaviour = knee_torque({"p": "+".join(["1"] * 30000), "q": 1.0})
    with pytest.warns(AllPointsFailedWarning):
        table = selfmanip.sweep(HOP, behaviour, over={"q": [1.0, 2.0, 3.0]}, q0=Q0H, t_final=0.01, threads=2)
    assert list(table["status"]) == ["expression"] * 3
    assert all("`parameters.p`" in str(err) for err in table["error"])


def test_a_chain_of_twenty_thousand_parameters_names_a_parameter():
    params = {f"c{i:05}": f"c{i + 1:05} + 1" for i in range(19999)}
    params["c19999"] = 1.0
    params["p"] = "c00000"
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, knee_torque(params), Q0H, t_final=0.01)
    assert "parameters.c" in e.value.field


@pytest.mark.parametrize("call", [
    lambda: selfmanip.leap("++", 0, 1e308),
    lambda: selfmanip.leap(swing_accel_rad_s2=1e308),
], ids=["gear_ratio_1e308", "swing_accel_1e308"])
def test_a_leap_at_1e308_ends_with_a_typed_outcome_instead_of_hanging(call):
    try:
        r = call()
    except SelfmanipError as e:
        assert e.field or "non-finite" in str(e) or "too large" in str(e), e
        return
    assert not r.flew or all(math.isfinite(x) for x in r.q_final)


@pytest.mark.parametrize("field", ["swing_accel_rad_s2", "swing_speed_rad_s"])
def test_a_swing_of_1e308_is_refused_naming_its_field(field):
    # finite, but the free legs' tracking law takes differences of values this large
    with pytest.raises(InvalidInputError) as e:
        selfmanip.leap(**{field: 1e308})
    assert e.value.field == field, e.value


def test_a_gear_ratio_of_1e308_is_refused_naming_the_gear_ratio():
    # finite, but the drive's reflected rotor inertia n J G² overflows: the ratio's fault,
    # not the servo gain the leap's behaviour derives from it
    with pytest.raises(InvalidInputError) as e:
        selfmanip.leap("++", 0.0, gear_ratio=1e308)
    assert e.value.field == "gear_ratio", e.value


def test_a_hopper_launched_at_1e308_ends_with_a_typed_error_instead_of_hanging():
    with pytest.raises(SelfmanipError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, [1e308] * 5)
    assert "non-finite" in str(e.value) or "too large" in str(e.value) or e.value.field


def test_a_hopper_placed_at_1e308_is_refused_before_an_infinite_energy():
    with pytest.raises(SelfmanipError) as e:
        selfmanip.simulate(HOP, HOPB, [1e308] * 5)
    assert "non-finite" in str(e.value) or "too large" in str(e.value) or e.value.field


def test_a_periodic_orbit_guess_at_1e308_is_a_typed_error_instead_of_a_hang():
    with pytest.raises(SelfmanipError):
        selfmanip.periodic_orbit(HOP, DATA / "hop_periodic.toml", Q0H, guess_qd0=[1e308] * 5)


def test_one_gear_ratio_of_1e308_keeps_its_seventeen_good_neighbours():
    table = leap_mod.sweep("++", [0.0, 0.05, 0.1], gear_ratio=[20.0, 25.0, 28.0, 1e308, 35.0, 40.0])
    status = list(table["status"])
    gears = list(table["gear_ratio"])
    bad = [f for f, g in zip(table["flew"], gears) if g == 1e308]
    good = [s for s, g in zip(status, gears) if g != 1e308]
    assert len(good) == 15 and len(bad) == 3
    assert not any(bad)


def test_contact_gaps_and_kinematics_at_1e308_are_typed_errors_not_nan():
    robot = selfmanip.Robot.from_file(DATA / "quadruped.toml")
    for f in (robot.contact_gaps, robot.forward_kinematics):
        with pytest.raises(SelfmanipError) as e:
            f([1e308] * 7)
        assert "non-finite" in str(e.value) or "too large" in str(e.value)


@pytest.mark.parametrize("terrain", [{"kind": "flat", "extra": 1}, {"kind": "ledge", "height_m": 0.1, "distance_m": 0.3, "x": 1}])
def test_unknown_terrain_keys_are_refused_with_the_known_ones(terrain):
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, terrain=terrain, t_final=0.01)
    assert e.value.field.startswith("terrain")
    assert "unknown field" in str(e.value)


@pytest.mark.parametrize("text", ["flat,x=1", "ledge,height_m=0.1,height_m=0.2,distance_m=0.3",
                                  '{"kind": "ledge", "height_m": 0.1, "height_m": 0.2, "distance_m": 0.3}'])
def test_cli_terrain_with_unknown_or_repeated_keys_is_refused(text):
    try:
        terrain = cli_sim.parse_terrain(text)
    except InvalidInputError as e:
        assert "twice" in str(e) and e.field.startswith("--terrain")
        return
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, terrain=terrain, t_final=0.01)
    assert e.value.field.startswith("terrain")


def test_empty_labels_are_refused():
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, t_final=0.01, labels=[])
    assert "labels" in e.value.field


@pytest.mark.parametrize("spec", [",,,", "foot,", "foot,foot"])
def test_mode_specs_with_empty_or_repeated_items_are_refused(spec):
    robot = selfmanip.Robot.from_file(HOP)
    with pytest.raises(InvalidInputError):
        robot.mode_spec(spec)
    assert robot.mode_spec("") == robot.mode_spec("  ")


def test_dynamics_with_a_contact_listed_twice_is_refused():
    robot = selfmanip.Robot.from_file(DATA / "quadruped.toml")
    q = [0.3, -0.6, 0.3, -0.6, 0.0, -0.5, 0.0]
    with pytest.raises(InvalidInputError):
        robot.dynamics("fore_foot,fore_foot", q, [0.0] * 7, [0.0] * 4)


def test_an_event_tolerance_of_a_second_is_refused():
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, t_final=0.01, event_tol_s=1.0)
    assert "event_tol_s" in e.value.field


def test_a_limp_sprung_leg_balances_its_energy_and_robot_energy_counts_the_spring():
    # the one-link sprung leg of the Rust spring tests, its spring 20 N m/rad; dropped from 2 m,
    # its foot stays in the air for the 0.3 s
    description = selfmanip.Robot.from_file(ROBOTS / "sprung_leg.toml").to_dict()
    description["legs"][0]["links"][0]["spring"] = {"stiffness_n_m_per_rad": 20.0}
    robot = selfmanip.Robot.from_dict(description)
    e = selfmanip.simulate(robot, None, [0.8, 0.0, -2.0, 0.0], t_final=0.3, rtol=1e-10)
    assert all(ev["kind"] != "touchdown" for ev in e.events), e.events
    er = e.energy_report()
    assert abs(er.residual_j) < 1e-6, er
    theta_end = e.q_end[0]
    assert abs(0.5 * 20.0 * (0.8 ** 2 - theta_end ** 2)) > 0.5   # what the old report missed
    # Robot.energy: the spring's ½kθ² on top of gravity's, same state, same robot
    _, v_bent = robot.energy([0.8, 0.0, -2.0, 0.0], [0.0] * 4)
    _, v_straight = robot.energy([0.0, 0.0, -2.0, 0.0], [0.0] * 4)
    # gravity: the leg's centre of mass (0.15 m along it, 0.3 kg) rises by 0.15 (1 − cos 0.8)
    dv_gravity = 0.3 * 9.81 * 0.15 * (1.0 - math.cos(0.8))
    assert v_bent - v_straight == pytest.approx(0.5 * 20.0 * 0.8 ** 2 + dv_gravity, rel=1e-12)
