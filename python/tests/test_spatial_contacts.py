"""The dict form of spatial contacts: sphere feet, Coulomb sliding and arcs, each against a
closed form, and bad entries as typed errors naming ``contacts[frame].key``."""

from pathlib import Path

import numpy as np
import pytest

from selfmanip import InvalidInputError, SpatialRobot

ROOT = Path(__file__).resolve().parents[2]
QUADRUPED = str(ROOT / "tests" / "data" / "urdf" / "quadruped12.urdf")

BALL = """<robot name="ball">
  <link name="ball"><inertial><origin xyz="0 0 0"/><mass value="1.5"/>
  <inertia ixx="0.006" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.006"/></inertial></link>
</robot>"""


def test_a_sliding_sphere_foot_has_the_closed_form_rates(tmp_path):
    """A uniform ball (m = 1.5 kg, r = 0.1 m) sliding and spinning on its sphere with
    ``mu = 0.4``: the ground pushes ``m g`` and ``-mu m g s`` (``s`` the contact point's sliding
    direction), so ``a = -mu g s`` and ``omega_dot = (5 mu g / 2 r) z x s``; the free flyer's
    body-frame rates at the identity orientation are ``a - omega x v`` and ``omega_dot``."""
    path = tmp_path / "ball.urdf"
    path.write_text(BALL)
    robot = SpatialRobot.from_urdf(str(path))
    r, mu, g, m = 0.1, 0.4, 9.81, 1.5
    q = robot.neutral()
    q[2] = r
    v = np.array([0.8, -0.3, 0.0, 1.0, 2.0, -0.5])
    out = robot.dynamics({"ball": {"radius_m": r, "friction": mu, "slide": True}}, q, v, np.zeros(6))
    lin, w = v[:3], v[3:]
    slip = lin + np.cross(w, [0.0, 0.0, -r])
    s = slip / np.linalg.norm(slip)
    want = np.concatenate([-mu * g * s - np.cross(w, lin), 5 * mu * g / (2 * r) * np.cross([0, 0, 1], s)])
    assert out.rows == [("ball", "n")]
    assert np.max(np.abs(out.qdd - want)) < 1e-12 * np.max(np.abs(want))
    assert abs(out.lam[0] - m * g) < 1e-12 * m * g


def test_dict_contacts_match_the_named_form_and_name_bad_fields():
    """``{"FL_foot": {"friction": mu}}`` is the named contact ``"FL_foot"`` (three rows),
    ``{"friction": 0}`` is ``"FL_foot:frictionless"``; a sphere foot of radius ``r`` moves the
    contact point ``r`` below the foot (rows ``A`` unchanged at a level, resting foot only in
    the columns that turn it); bad entries name ``contacts[frame].key``."""
    robot = SpatialRobot.from_urdf(QUADRUPED)
    q = robot.neutral()
    q[2] = 0.5
    v, tau = np.zeros(robot.nv), np.zeros(robot.nv)
    named = robot.dynamics(["FL_foot", "FR_foot:frictionless"], q, v, tau)
    as_dict = robot.dynamics({"FL_foot": {"friction": 0.8}, "FR_foot": {"friction": 0.0}}, q, v, tau)
    assert as_dict.rows == named.rows
    assert np.array_equal(as_dict.qdd, named.qdd) and np.array_equal(as_dict.lam, named.lam)
    sphere = robot.dynamics({"FL_foot": {"radius_m": 0.02, "friction": 0.8}}, q, v, tau)
    point = robot.dynamics({"FL_foot": {"friction": 0.8}}, q, v, tau)
    # the base's translation columns do not see the offset; the rotation columns do
    assert np.max(np.abs(sphere.A[:, :3] - point.A[:, :3])) < 1e-15
    assert np.max(np.abs(sphere.A[:, 3:6] - point.A[:, 3:6])) > 1e-3
    for contacts, field in [
        ({"FL_foot": {"radius_m": -0.1}}, "contacts[FL_foot].radius_m"),
        ({"FL_foot": {"friction": -1.0}}, "contacts[FL_foot].friction"),
        ({"FL_foot": {"friction": 0.5, "slide": True, "radius_m": float("nan")}}, "contacts[FL_foot].radius_m"),
        ({"FL_foot": {"stiffness": 1.0}}, "contacts[FL_foot].stiffness"),
        ({"FL_foot": {"normal": [0.0, 0.0, 0.0]}}, "contacts[FL_foot].normal"),
        ({"FL_foot": {"radius_m": 0.1, "arc": {"axis": [0, 1, 0], "zero": [0, 0, -1],
                                                "angle_range_rad": [1.0, 0.0]}}},
         "contacts[FL_foot].arc.angle_range_rad"),
        ({"FL_foot": {"radius_m": 0.1, "arc": {"axis": [0, 1, 0], "zero": [0, 1, 0],
                                                "angle_range_rad": [0.0, 1.0]}}},
         "contacts[FL_foot].arc.zero"),
        ({"no_such_foot": {"friction": 0.5}}, "contacts"),
    ]:
        with pytest.raises(InvalidInputError) as e:
            robot.dynamics(contacts, q, v, tau)
        assert e.value.field == field, (contacts, e.value.field)
    # sliding needs a sliding velocity
    with pytest.raises(InvalidInputError) as e:
        robot.dynamics({"FL_foot": {"friction": 0.5, "slide": True}}, q, v, tau)
    assert e.value.field == "v"


def test_rhex_c_leg_arc_rolls_on_its_half_circle_and_pivots_on_its_toe():
    """RHex's C-leg as the documented arc (the forward half circle of radius 0.085 about
    ``front_left_arc``, from the toe at angle 0 to the hip at pi): with the legs turned by
    +0.5 rad the circle's lowest point lies on the half circle, and the rows are the whole
    circle's (the arc over ``[0, 2 pi]``); turned by -0.5 rad it lies on the missing half, and
    the arc touches at its lower end, the toe (the named contact ``front_left_toe``)."""
    rhex = SpatialRobot.rhex(leg_mass_kg=0.063, leg_inertia_kg_m2=0.00046)
    v, tau = np.linspace(-1.0, 1.0, rhex.nv), np.zeros(rhex.nv)

    def arc(to_rad):
        return {"front_left_arc": {"radius_m": 0.085, "friction": 0.8, "arc": {
            "axis": [0, -1, 0], "zero": [0, 0, -1], "angle_range_rad": [0.0, to_rad]}}}

    for angle, other in [(0.5, arc(2 * np.pi)), (-0.5, ["front_left_toe"])]:
        q = rhex.neutral()
        q[2] = 0.3
        q[7:] = angle
        half = rhex.dynamics(arc(np.pi), q, v, tau)
        ref = rhex.dynamics(other, q, v, tau)
        assert [r[1] for r in half.rows] == ["t1", "t2", "n"]
        assert np.max(np.abs(half.A - ref.A)) < 1e-12, angle
        assert np.max(np.abs(half.drift - ref.drift)) < 1e-12 and np.max(np.abs(ref.drift)) > 1e-3, angle
