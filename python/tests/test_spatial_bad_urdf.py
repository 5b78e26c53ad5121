"""Every bad URDF of issue 32 (a cycle, a missing parent, a second parent, a negative or NaN
mass, a NaN origin, an unsupported joint type, a malformed number or vector, a missing
attribute, unparsable XML) raises ``InvalidInputError``
naming its field in Python, the field the Rust reader names
(``crates/selfmanip-core/tests/spatial_urdf.rs``)."""

from __future__ import annotations

import pathlib

import numpy as np
import pytest

from selfmanip import SpatialRobot
from selfmanip.errors import InvalidInputError

LINKS = (
    '<link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/>'
    '</inertial></link><link name="b"><inertial><mass value="{mass_b}"/>'
    '<inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>'
)


def joint(name: str, kind: str, parent: str, child: str, xyz: str = "0 0 1") -> str:
    return (f'<joint name="{name}" type="{kind}"><origin xyz="{xyz}"/><parent link="{parent}"/>'
            f'<child link="{child}"/><axis xyz="0 0 1"/>'
            '<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>')


def two_links(tmp_path: pathlib.Path, joints: str, mass_b: str = "0.5") -> pathlib.Path:
    path = tmp_path / "robot.urdf"
    path.write_text(f'<robot name="r">{LINKS.format(mass_b=mass_b)}{joints}</robot>')
    return path


def test_a_good_two_link_robot_loads(tmp_path):
    robot = SpatialRobot.from_urdf(two_links(tmp_path, joint("j", "revolute", "a", "b")))
    assert (robot.nq, robot.nv) == (8, 7)
    assert robot.joint_names == ["root_joint", "j"]


CASES = {
    "cycle": (joint("j1", "revolute", "a", "b") + joint("j2", "revolute", "b", "a"), "0.5", "joint[j"),
    "second_parent": (joint("j1", "revolute", "a", "b") + joint("j2", "fixed", "a", "b"), "0.5", "joint[j2].child"),
    "missing_parent": (joint("j", "revolute", "nowhere", "b"), "0.5", "joint[j].parent"),
    "negative_mass": (joint("j", "revolute", "a", "b"), "-0.5", "link[b].inertial.mass"),
    "nan_mass": (joint("j", "revolute", "a", "b"), "NaN", "link[b].inertial.mass"),
    "nan_origin": (joint("j", "revolute", "a", "b", "0 NaN 1"), "0.5", "joint[j].origin.xyz"),
    "planar_joint": (joint("j", "planar", "a", "b"), "0.5", "joint[j].type"),
    "unknown_joint_type": (joint("j", "bogus", "a", "b"), "0.5", "joint[j].type"),
    # what the XML parser refuses is named too (as in `pybullet_data`: a bicycle's commas, a
    # biped's `-1.57.`, an unexpanded xacro expression)
    "commas_in_a_vector": (joint("j", "revolute", "a", "b", "0, 0, 1"), "0.5", "joint[j].origin.xyz"),
    "two_points_in_a_number": (joint("j", "revolute", "a", "b").replace('lower="-1"', 'lower="-1.57."'),
                               "0.5", "joint[j].limit.lower"),
    "xacro_expression": (joint("j", "revolute", "a", "b", "$(arg x) 0 1"), "0.5", "joint[j].origin.xyz"),
    "no_velocity_limit": (joint("j", "revolute", "a", "b").replace(' velocity="1"', ""), "0.5",
                          "joint[j].limit.velocity"),
    "mass_not_a_number": (joint("j", "revolute", "a", "b"), "half", "link[b].inertial.mass"),
}


@pytest.mark.parametrize("case", list(CASES))
def test_bad_urdf_names_the_field(tmp_path, case):
    joints, mass_b, field = CASES[case]
    with pytest.raises(InvalidInputError) as e:
        SpatialRobot.from_urdf(two_links(tmp_path, joints, mass_b))
    # a cycle is reported on whichever of its joints the reader meets first
    assert e.value.field.startswith(field) if case == "cycle" else e.value.field == field, e.value.field


def test_missing_file_and_bad_base_name_the_field(tmp_path):
    with pytest.raises(InvalidInputError) as e:
        SpatialRobot.from_urdf(tmp_path / "no_such.urdf")
    assert e.value.field == "urdf", e.value.field
    with pytest.raises(InvalidInputError) as e:
        SpatialRobot.from_urdf(two_links(tmp_path, joint("j", "revolute", "a", "b")), base="floating")
    assert e.value.field == "base"


def test_an_element_urdfdom_reads_once_is_read_as_pinocchio_reads_it(tmp_path):
    # urdfdom, Pinocchio's reader, takes the first of a joint's `axis`, `origin`, `limit`, a
    # link's `inertial` and an inertial's `mass` (Spirit 40 in `pybullet_data` gives a joint
    # two axes); a second one is no error and changes nothing
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (`pip install pin`, in the test extra) is the independent route")
    from pinocchio_routes import kinematics_errors

    repeated = (
        '<joint name="j" type="revolute"><origin xyz="0.1 0.2 0.3" rpy="0.3 0 0.2"/><origin xyz="5 5 5"/>'
        '<parent link="a"/><child link="b"/><axis xyz="0 1 0"/><axis xyz="1 0 0"/>'
        '<limit lower="-1" upper="1" effort="1" velocity="1"/><limit lower="-2" upper="2" effort="1" velocity="1"/>'
        '</joint>')
    links = LINKS.format(mass_b="0.5").replace(
        '</inertial></link><link name="b">',
        '<mass value="7"/></inertial><inertial><mass value="9"/><inertia ixx="2" ixy="0" ixz="0" iyy="2" iyz="0" izz="2"/>'
        '</inertial></link><link name="b">')
    path = tmp_path / "repeated.urdf"
    path.write_text(f'<robot name="r">{links}{repeated}</robot>')
    ours = SpatialRobot.from_urdf(path)
    model = pin.buildModelFromUrdf(str(path), pin.JointModelFreeFlyer())
    assert model.inertias[1].mass == 1.0 and ours.joint_names == list(model.names)[1:]
    rng = np.random.default_rng(7)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq))
    v = rng.normal(size=model.nv)
    errors = kinematics_errors(ours, model, model.createData(), q, v, ["a", "b", "j"])
    assert max(errors.values()) < 1e-12, errors
