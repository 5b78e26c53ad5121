"""A massless limb in the air follows the motion the caller gives (thesis 5.1.1, as the planar
core's free joints): the quadruped with massless shins on three feet leaves its fourth shin
free. The second route is the same URDF with that knee welded (``type="fixed"``): a massless
shin moves no mass, so the other rates and the contact forces are that robot's whatever the
shin does."""

from __future__ import annotations

import pathlib
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from selfmanip import SpatialRobot
from selfmanip.errors import InvalidInputError, SingularKktError

ROOT = pathlib.Path(__file__).resolve().parents[2]
QUADRUPED = ROOT / "tests" / "data" / "urdf" / "quadruped12.urdf"
FEET = ["FL_foot", "FR_foot", "HL_foot"]


def massless_shins(tmp_path: pathlib.Path, weld: str | None = None) -> pathlib.Path:
    tree = ET.parse(QUADRUPED)
    root = tree.getroot()
    for link in root.iter("link"):
        if link.get("name", "").endswith(("_shin", "_foot")):
            inertial = link.find("inertial")
            inertial.find("mass").set("value", "0")
            for k in inertial.find("inertia").attrib:
                inertial.find("inertia").set(k, "0")
    for joint in root.iter("joint"):
        if joint.get("name") == weld:
            joint.set("type", "fixed")
    path = tmp_path / f"quadruped_massless_shins_{weld}.urdf"
    tree.write(path)
    return path


def random_state(rng, robot):
    q = robot.neutral()
    q[2] = 0.4
    q[7:] = rng.uniform(-1.0, 1.0, robot.nq - 7)
    return q, rng.uniform(-1, 1, robot.nv), np.concatenate([np.zeros(6), rng.uniform(-3, 3, robot.nv - 6)])


def test_free_shin_follows_its_motion_and_the_rest_is_the_welded_robot(tmp_path):
    robot = SpatialRobot.from_urdf(massless_shins(tmp_path))
    welded = SpatialRobot.from_urdf(massless_shins(tmp_path, weld="HR_knee"))
    knee = robot.joint_names.index("HR_knee") - 1 + 6  # after the free flyer's six rates
    assert robot.free_rates(FEET) == [knee] == [robot.nv - 1]
    assert robot.free_rates(FEET + ["HR_foot"]) == []
    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(10):
        q, v, tau = random_state(rng, robot)
        with pytest.raises(SingularKktError):
            robot.dynamics(FEET, q, v, tau)
        a = rng.uniform(-40, 40)
        out = robot.dynamics(FEET, q, v, tau, free_qdd=[a])
        # the free rate's row of the solved system is unit * qdd = unit * a
        assert abs(out.qdd[knee] - a) <= 1e-14 * abs(a)
        keep = np.arange(robot.nv) != knee
        ref = welded.dynamics(FEET, np.delete(q, 7 + knee - 6), v[keep], tau[keep])
        worst = max(worst, np.max(np.abs(out.qdd[keep] - ref.qdd)) / max(1.0, np.max(np.abs(ref.qdd))),
                    np.max(np.abs(out.lam - ref.lam)) / max(1.0, np.max(np.abs(ref.lam))))
        # the impact leaves the free shin's rate as it was
        imp = robot.impact(FEET, q, v)
        assert imp.v_plus[knee] == v[knee]
        ref_imp = welded.impact(FEET, np.delete(q, 7 + knee - 6), v[keep])
        worst = max(worst, np.max(np.abs(imp.v_plus[keep] - ref_imp.v_plus)) / max(1.0, np.max(np.abs(v))))
    print(f"free shin against the welded robot: {worst:.1e}")
    assert worst < 1e-12, worst


def test_free_qdd_of_the_wrong_length_names_the_field(tmp_path):
    robot = SpatialRobot.from_urdf(massless_shins(tmp_path))
    q = robot.neutral()
    with pytest.raises(InvalidInputError) as e:
        robot.dynamics(FEET, q, np.zeros(robot.nv), np.zeros(robot.nv), free_qdd=[1.0, 2.0])
    assert e.value.field == "free_qdd"
