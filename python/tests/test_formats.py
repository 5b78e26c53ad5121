"""A URDF or MJCF file given where a planar description is read (``Robot.from_file``,
``simulate``, ``sweep``) is a typed "unsupported format" error that names the argument and
points to ``selfmanip.SpatialRobot.from_urdf``, not a TOML parse error (issue 30, item 7);
the same URDF loads with ``SpatialRobot.from_urdf``."""

from __future__ import annotations

import pathlib
import shutil

import pytest

import selfmanip
from selfmanip.errors import InvalidInputError

ROOT = pathlib.Path(__file__).resolve().parents[2]
URDF = ROOT / "tests" / "data" / "urdf" / "quadruped12.urdf"
Q0 = [0.0] * 11


@pytest.mark.parametrize("name", ["robot.urdf", "robot.URDF", "robot.xml", "scene.mjcf", "robot.sdf"])
def test_from_file_refuses_other_formats_by_name(tmp_path, name) -> None:
    path = tmp_path / name
    shutil.copy(URDF, path)
    with pytest.raises(InvalidInputError) as e:
        selfmanip.Robot.from_file(path)
    assert e.value.field == "path"
    assert "unsupported format" in str(e.value) and "SpatialRobot.from_urdf" in str(e.value)
    assert "TOML" not in str(e.value) and "toml parse" not in str(e.value).lower()


def test_xml_text_under_a_toml_name_is_refused_too(tmp_path) -> None:
    path = tmp_path / "robot.toml"
    shutil.copy(URDF, path)
    with pytest.raises(InvalidInputError, match="SpatialRobot.from_urdf") as e:
        selfmanip.Robot.from_file(path)
    assert e.value.field == "path"


def test_simulate_and_sweep_name_the_robot_argument() -> None:
    with pytest.raises(InvalidInputError, match="SpatialRobot.from_urdf") as e:
        selfmanip.simulate(URDF, None, Q0)
    assert e.value.field == "robot"
    with pytest.raises(InvalidInputError, match="SpatialRobot.from_urdf"):
        selfmanip.sweep(robot=URDF, over={"x": [0.0]}, q0=Q0)


def test_the_pointer_is_right() -> None:
    r = selfmanip.SpatialRobot.from_urdf(URDF)
    assert r.nv > 0
