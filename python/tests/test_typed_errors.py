"""Issue 31, items 7 and 8: the inputs that raised a generic error (``OverflowError``, a bare
``TypeError``, ``AttributeError``, ``UnicodeError``, ``OSError``) or a CLI traceback now raise a
typed :class:`selfmanip.errors.SelfmanipError` naming the field; writes that fail or are
interrupted leave no file behind and name the file asked for."""

from __future__ import annotations

import os
import pathlib
import signal
import subprocess
import sys

import numpy as np
import pytest

import selfmanip
from selfmanip import cli, motor
from selfmanip._tables import write_atomically, write_table
from selfmanip.errors import InvalidInputError, InvalidTypeError, SingularKktError

from conftest import QUADRUPED

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
HOP, HOPB = DATA / "hopper.toml", DATA / "hop.toml"
Q0H = [0.5, -1.0, 0.0, -0.451, 0.0]


def test_a_jacobian_part_beyond_64_bits_names_part():
    # OverflowError naming nothing before
    robot = selfmanip.Robot.from_file(QUADRUPED)
    with pytest.raises(InvalidInputError) as e:
        robot.jacobian([0.0] * robot.nq, 10**20)
    assert e.value.field == "part"


@pytest.mark.parametrize("sweep", [
    lambda **kw: selfmanip.sweep("++", t2=0.0, **kw),
    lambda **kw: selfmanip.sweep(HOP, HOPB, over={"kp_push": [30.0]}, q0=Q0H, t_final=0.01, **kw),
], ids=["leap", "any_robot"])
def test_a_sweep_progress_that_is_neither_a_flag_nor_callable_names_progress(sweep):
    # "'str' object is not callable" before
    with pytest.raises(InvalidTypeError) as e:
        sweep(progress="yes")
    assert e.value.field == "progress"


def test_a_sweep_config_that_is_not_a_dict_names_config():
    # "cannot convert dictionary update sequence element #0" before
    with pytest.raises(InvalidTypeError) as e:
        selfmanip.sweep("++", t2=0.0, config=[1])
    assert e.value.field == "config"


def test_simulate_params_that_are_not_a_dict_name_params():
    # AttributeError: 'list' object has no attribute 'items' before
    with pytest.raises(InvalidTypeError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, t_final=0.01, params=[1])
    assert e.value.field == "params"


def test_text_without_a_utf8_form_names_the_argument():
    # UnicodeEncodeError naming nothing before
    with pytest.raises(InvalidInputError) as e:
        selfmanip.Robot.from_json("\ud800")
    assert e.value.field == "text"


def test_a_binary_description_file_names_path_and_the_file(tmp_path):
    # UnicodeDecodeError naming neither before
    path = tmp_path / "robot.toml"
    path.write_bytes(b"\xff\xfe\x00name = 1\x80")
    with pytest.raises(InvalidInputError) as e:
        selfmanip.Robot.from_file(path)
    assert e.value.field == "path"
    assert str(path) in str(e.value)


def test_an_empty_behaviour_file_is_invalid_input_naming_the_file(tmp_path):
    # a plain OSError before
    path = tmp_path / "empty.toml"
    path.write_text("")
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, path, Q0H, t_final=0.01)
    assert e.value.field == str(path)
    assert "empty" in str(e.value)


def test_an_initial_contact_listed_twice_names_the_second():
    # "off the constraint manifold" (an EngineError) before
    with pytest.raises(InvalidInputError) as e:
        selfmanip.simulate(HOP, HOPB, Q0H, contacts="foot,foot", t_final=0.01)
    assert e.value.field == "initial.contacts[1]"
    assert "listed twice" in str(e.value)


@pytest.mark.parametrize("argv, field", [
    (["leap", "--set", "gear_ratio=28"], "--set gear_ratio"),    # "leap() got multiple values"
    (["leap", "--set", "t2=0.1"], "--set t2"),
    (["sweep", "--set", "gear_ratio=20,28"], "--set gear_ratio"),
    (["leap", "--set", "m_b=8", "--set", "m_b=9"], "--set m_b"),  # kept the last before
])
def test_cli_set_of_an_input_with_its_own_option_or_twice_is_refused(argv, field, capsys):
    assert cli.main(argv) == 2
    assert f"`{field}`" in capsys.readouterr().err


def test_cli_sweep_over_a_range_beyond_the_bound_names_the_option(capsys):
    # numpy's ArrayMemoryError traceback before
    argv = ["sweep", "--robot", str(HOP), "--behaviour", str(HOPB), "--q0=" + ",".join(map(str, Q0H)),
            "--over", "kp_push=35:55:1e12"]
    assert cli.main(argv) == 2
    assert "--over kp_push" in capsys.readouterr().err


def one_leg_robot(links: list[dict]) -> dict:
    return {"name": "degenerate", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.02},
            "legs": [{"name": "leg", "hip_m": [0.0, 0.0], "links": links}]}


@pytest.mark.parametrize("links, joints, field", [
    # a point mass on the joint axis: turning the joint moves nothing (M̄'s row of θ is zero)
    ([{"length_m": 0.0, "mass_kg": 0.3, "inertia_kg_m2": 0.0}], ["leg"], "legs[0].links[0]"),
    # a massless link of length zero before a massive one: θ₀ = −θ₁ leaves the massive link in
    # place and its angle unchanged, the null vector (1, −1) of M̄ over the two joints
    ([{"length_m": 0.0, "mass_kg": 0.0, "inertia_kg_m2": 0.0},
      {"length_m": 0.2, "mass_kg": 0.3, "inertia_kg_m2": 0.002}], ["leg[0]", "leg[1]"], "legs[0].links[0]"),
], ids=["point_mass_on_the_axis", "massless_link_before_a_massive_one"])
def test_motion_without_inertia_names_its_joints_and_link(links, joints, field):
    # SingularKktError(UnconstrainedMasslessMotion) naming no link before
    robot = one_leg_robot(links)
    with pytest.raises(SingularKktError) as e:
        selfmanip.simulate(robot, None, [0.3] * len(links) + [0.0, -0.5, 0.0], t_final=0.05)
    assert e.value.kind == "UnconstrainedMasslessMotion"
    assert e.value.field == field
    for j in joints:
        assert f"`{j}`" in str(e.value)
    # a second route: the motion of the named joints has no kinetic energy (4.24) in the
    # Robot's own M̄, and turning the first joint alone has some unless it is the only one
    q = [0.3] * len(links) + [0.0, -0.5, 0.0]
    null = [1.0, -1.0][:len(links)] + [0.0] * 3
    kinetic, _ = selfmanip.Robot.from_dict(robot).energy(q, null)
    assert abs(kinetic) < 1e-15
    if len(links) > 1:
        assert selfmanip.Robot.from_dict(robot).energy(q, [1.0] + [0.0] * (len(q) - 1))[0] > 1e-3


def test_a_table_write_stopped_midway_leaves_neither_the_table_nor_a_temp_file(tmp_path):
    # Ctrl-C during a CSV write left `big.csv.<pid>.tmp` before
    target = tmp_path / "big.csv"

    def interrupted(tmp: str) -> None:
        with open(tmp, "w") as f:
            f.write("a,b\n1,2\n")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        write_atomically(str(target), interrupted)
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_a_table_into_a_missing_directory_names_the_target(tmp_path, suffix):
    # the error named the temp file before
    target = tmp_path / "no" / f"t{suffix}"
    with pytest.raises(FileNotFoundError) as e:
        write_table({"x": np.arange(3.0)}, str(target))
    assert e.value.filename == str(target)
    assert ".tmp" not in str(e.value)
    assert os.listdir(tmp_path) == []


def test_an_mcap_into_a_missing_directory_names_the_target(tmp_path):
    e = selfmanip.simulate(HOP, HOPB, Q0H, t_final=0.02)
    target = tmp_path / "no" / "run.mcap"
    with pytest.raises(FileNotFoundError) as err:
        e.to_mcap(target)
    assert str(target) in str(err.value)
    assert ".tmp" not in str(err.value)


MCAP_WRITER = """
import sys, selfmanip
from selfmanip.cli import EXIT_INTERRUPTED
e = selfmanip.simulate(sys.argv[1], sys.argv[2], [0.5, -1.0, 0.0, -0.451, 0.0], t_final=1.0)
print("ready", flush=True)
try:
    e.to_mcap(sys.argv[3], dt=2.5e-5)   # 40,000 samples: some 200 MB of JSON records
except KeyboardInterrupt:
    sys.exit(EXIT_INTERRUPTED)
print("finished", flush=True)
"""


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
def test_ctrl_c_during_an_mcap_write_exits_130_and_leaves_no_file(tmp_path):
    # took 6.6 s and left the complete file before
    target = tmp_path / "big.mcap"
    script = tmp_path / "write.py"
    script.write_text(MCAP_WRITER)
    p = subprocess.Popen([sys.executable, str(script), str(HOP), str(HOPB), str(target)],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "ready"
    # the write has begun once its temporary file exists: interrupt it there
    tmp_name = f".big.mcap.{p.pid}.tmp"
    for _ in range(24000):  # up to two minutes in 5 ms waits: a bound, not a timing
        if (tmp_path / tmp_name).exists():
            break
        try:
            p.wait(timeout=0.005)
            break  # it ended without writing: the assertion below says so
        except subprocess.TimeoutExpired:
            pass
    assert (tmp_path / tmp_name).exists(), "the write never started"
    p.send_signal(signal.SIGINT)
    out, err = p.communicate(timeout=120)
    assert p.returncode == 130, err
    assert "finished" not in out
    assert sorted(os.listdir(tmp_path)) == ["write.py"]
