"""Bad inputs of the adversarial audit (issue 31) through Python and the CLI: each a typed
error naming the field, or a correct finite result, never a crash, a hang, a huge allocation
or a NaN. (The actuator models', and the nesting and size of structured inputs.)"""

import math

import numpy as np
import pytest

import selfmanip
from selfmanip import cli, motor
from selfmanip.errors import InvalidInputError, InvalidTypeError

from conftest import QUADRUPED

P = {"k_m": 50.0, "a_m": 20.0, "k_p": 10.0, "k_d": 0.5, "k_g": -1.0, "theta_g_rad": 0.0, "delay_s": 0.012}
LOG = [np.zeros(200)] * 4


def test_observe_with_a_delay_of_1e308_names_delay_s_instead_of_panicking():
    with pytest.raises(InvalidInputError) as e:
        motor.observe(dict(P, delay_s=1e308), 1e-3, *LOG)
    assert e.value.field == "delay_s"


def test_observe_rejects_unknown_keys():
    with pytest.raises(InvalidInputError, match="unknown field `delay`"):
        motor.observe(dict(P, delay=0.01), 1e-3, *LOG)


def test_torque_speed_curve_points_are_bounded_and_catalog_toml_typed():
    with pytest.raises(InvalidInputError) as e:
        motor.torque_speed_curve("x-rhex-28", points=10**9)
    assert e.value.field == "points"
    with pytest.raises(InvalidTypeError) as e:
        motor.torque_speed_curve("x-rhex-28", catalog_toml=5)
    assert e.value.field == "catalog_toml"


@pytest.mark.parametrize("torque, ambient, field", [
    ([1e308] * 10, 25.0, "torque_n_m"),   # Joule heat overflows: NaN temperatures before
    ([], 25.0, "torque_n_m"),             # an empty profile was accepted
    ([1.0], -300.0, "ambient_c"),         # below absolute zero
])
def test_thermal_simulation_bad_profiles_name_their_field(torque, ambient, field):
    with pytest.raises(InvalidInputError) as e:
        motor.thermal_simulation("x-rhex-28", np.asarray(torque, dtype=float), ambient_c=ambient)
    assert e.value.field == field


def test_tail_optimum_at_a_huge_rotation_is_finite_and_scales_as_eq_2_1():
    # Ω* ∝ θ0^(1/3), t* ∝ θ0^(2/3): the optimum at 1e300 is the one at 1 scaled by 1e100, 1e200
    one = motor.tail_optimum(1.0, 30.0, 0.05, 1.29)
    huge = motor.tail_optimum(1e300, 30.0, 0.05, 1.29)
    assert huge["no_load_speed_rad_s"] == pytest.approx(one["no_load_speed_rad_s"] * 1e100, rel=1e-13)
    assert huge["completion_time_s"] == pytest.approx(one["completion_time_s"] * 1e200, rel=1e-13)
    assert all(math.isfinite(v) for v in motor.tail_optimum(1e308, 30.0, 0.05, 1.29).values())


def test_rank_tail_motors_checks_nan_constraints_and_huge_seeds():
    with pytest.raises(InvalidInputError) as e:
        motor.rank_tail_motors(1.57, 0.05, 1.29, max_length_m=float("nan"))
    assert e.value.field == "max_length_m"
    with pytest.raises(InvalidInputError) as e:
        motor.rank_tail_motors(1.57, 0.05, 1.29, seed=10**30)
    assert e.value.field == "seed"
    with pytest.raises(InvalidInputError) as e:
        motor.rank_tail_motors(1.57, 0.05, 1.29, synthetic_count=10**9)
    assert e.value.field == "synthetic_count"


def test_cli_motor_with_an_overflowing_torque_fails_naming_it(capsys):
    # printed "core nan C" with exit status 0
    assert cli.main(["motor", "--torque=1e308"]) == 2
    assert "torque_n_m" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["motor", "--duration=1e12"], ["motor", "--duration=1e7", "--dt=1e-3"]])
def test_cli_motor_with_too_many_samples_fails_before_allocating(argv, capsys):
    # numpy's ArrayMemoryError traceback before
    assert cli.main(argv) == 2
    assert "--duration" in capsys.readouterr().err


@pytest.mark.parametrize("where", ["robot", "behaviour"])
def test_a_description_nested_30000_deep_is_an_error_not_a_stack_overflow(where):
    # SIGSEGV before: the dict-to-value conversion recursed once per level
    deep: list = []
    for _ in range(30000):
        deep = [deep]
    robot = {"name": "r", "body": {"mass_kg": 1.0, "inertia_kg_m2": 0.1}, "legs": deep}
    behaviour = {"joints": deep}
    with pytest.raises(InvalidInputError, match="nested deeper than"):
        if where == "robot":
            selfmanip.simulate(robot, None, [0.0, 0.0, 0.0], t_final=0.01)
        else:
            selfmanip.simulate(str(QUADRUPED), behaviour, [0.0] * 7, t_final=0.01)


def test_integers_beyond_64_bits_name_their_field():
    # OverflowError naming nothing before
    with pytest.raises(InvalidInputError) as e:
        selfmanip.rhex.Model().contact_mode_map(10**20)
    assert e.value.field == "n"


def test_a_leap_parameter_given_twice_is_refused():
    # `leap(params={'m_b': 5}, m_b=9)` ran with 9
    with pytest.raises(InvalidInputError) as e:
        selfmanip.leap("++", 0.0, params={"m_b": 5.0}, m_b=9.0)
    assert e.value.field == "m_b"


@pytest.mark.parametrize("argv, field", [
    (["sweep", "--t2=0:1:1e11"], "--t2"),
])
def test_cli_ranges_beyond_the_bound_fail_before_numpy_allocates(argv, field, capsys):
    # numpy's ArrayMemoryError traceback before
    assert cli.main(argv) == 2
    assert field in capsys.readouterr().err


@pytest.mark.parametrize("argv, option", [
    (["leap", "--mcap", ""], "--mcap"),          # accepted before
    (["sweep", "--out", ""], "--out"),           # wrote the table to stdout
    (["plot", "x.csv", "--out", ""], "--out"),   # wrote `.png`
    (["simulate", "r.toml", "--plot", ""], "--plot"),
    (["analysis", "fig4.8", "--out", ""], "--out"),
    (["chapter3", "--out-dir", ""], "--out-dir"),
])
def test_cli_empty_output_paths_are_refused_naming_the_option(argv, option, capsys):
    with pytest.raises(SystemExit) as e:
        cli.main(argv)
    assert e.value.code == 2
    assert f"argument {option}" in capsys.readouterr().err


def test_cli_strategy_list_with_an_empty_item_is_refused(capsys):
    # `--strategy=++,,` ran `++` alone
    assert cli.main(["sweep", "--strategy=++,,", "--t2=0"]) == 2
    assert "--strategy" in capsys.readouterr().err


@pytest.mark.parametrize("n", ["0", "100000"])
def test_cli_figure_grid_out_of_range_names_n(n, capsys):
    # `--n=0` drew the default grid, `--n=100000` had no limit
    assert cli.main(["analysis", "fig4.8", f"--n={n}"]) == 2
    assert "`n`" in capsys.readouterr().err


def test_chapter3_does_not_create_a_tree_from_a_mistyped_path(tmp_path):
    from selfmanip.chapter3 import run

    with pytest.raises(InvalidInputError) as e:
        run(str(tmp_path / "no" / "such" / "dir"), n=1)
    assert e.value.field == "out_dir"
    assert not (tmp_path / "no").exists()


def test_a_trajectory_of_too_many_samples_names_dt_s():
    # leap(dt=1e-9) grew ~270 MB/s; Execution.trajectory(1e-12) reached 3.5 GB
    with pytest.raises(InvalidInputError) as e:
        selfmanip.leap("++", 0.0, dt=1e-12)
    assert e.value.field == "dt_s"


def test_a_urdf_path_of_the_wrong_type_names_path():
    with pytest.raises(InvalidTypeError) as e:
        selfmanip.SpatialRobot.from_urdf(5)
    assert e.value.field == "path"

