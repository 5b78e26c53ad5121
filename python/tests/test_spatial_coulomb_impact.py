"""The Coulomb plastic impact of spatial contacts from Python (dict contacts with
``friction``): a ball striking the ground obliquely against its closed form, the sticking limit
against the named (sticking) form, and the typed error naming ``contacts``."""

from pathlib import Path

import numpy as np
import pytest

from selfmanip import InvalidInputError, InvalidTypeError, SpatialRobot

ROOT = Path(__file__).resolve().parents[2]
QUADRUPED = str(ROOT / "tests" / "data" / "urdf" / "quadruped12.urdf")
FEET = ["FL_foot", "FR_foot", "HL_foot", "HR_foot"]

BALL = """<robot name="ball">
  <link name="ball"><inertial><origin xyz="0 0 0"/><mass value="1.5"/>
  <inertia ixx="0.006" ixy="0" ixz="0" iyy="0.006" iyz="0" izz="0.006"/></inertial></link>
</robot>"""


@pytest.mark.parametrize("stick", [True, False])
def test_ball_striking_the_ground_obliquely(tmp_path, stick):
    """A uniform ball (m = 1.5 kg, r = 0.1 m, I = k m r^2, k = 2/5) hits the ground with
    contact-point velocity ``u``: ``P_n = -m u_n``; it sticks (``P_t = -m k/(1+k) u_t``) iff
    ``k/(1+k)|u_t| <= mu |u_n|``, else slides with ``P_t = -mu P_n u_t/|u_t|``; then
    ``v+ = v + P/m``, ``omega+ = omega + (r x P)/(k m r^2)`` at the identity orientation."""
    path = tmp_path / "ball.urdf"
    path.write_text(BALL)
    robot = SpatialRobot.from_urdf(str(path))
    r, m, k = 0.1, 1.5, 0.4
    q = robot.neutral()
    q[2] = r
    v = np.array([0.8, -0.3, -1.2, 4.0, 7.0, -2.5])
    arm = np.array([0.0, 0.0, -r])
    u = v[:3] + np.cross(v[3:], arm)
    u_t = np.array([u[0], u[1], 0.0])
    mu = k / (1 + k) * np.linalg.norm(u_t) / -u[2] * (1.05 if stick else 0.95)
    p_n = -m * u[2]
    p_t = -m * k / (1 + k) * u_t if stick else -mu * p_n * u_t / np.linalg.norm(u_t)
    p = p_t + np.array([0.0, 0.0, p_n])
    want = np.concatenate([v[:3] + p / m, v[3:] + np.cross(arm, p) / (k * m * r * r)])
    out = robot.impact({"ball": {"radius_m": r, "friction": mu}}, q, v)
    assert out.states == ["stick" if stick else "slip"]
    assert out.rows == [("ball", "t1"), ("ball", "t2"), ("ball", "n")]
    assert np.max(np.abs(out.v_plus - want)) < 1e-13 * np.max(np.abs(want))
    assert np.max(np.abs(out.impulse - p)) < 1e-13 * np.max(np.abs(p))


def test_large_friction_is_the_sticking_impact():
    """Four feet landing with ``mu = 1000``: the impulses lie well inside the cones, so the
    impact is the sticking one of the named contacts, bit for bit."""
    robot = SpatialRobot.from_urdf(QUADRUPED)
    rng = np.random.default_rng(5)
    q = robot.neutral()
    q[2] = 0.4
    q[7:] = np.tile([0.0, 0.5, -1.0], 4) + rng.uniform(-0.2, 0.2, 12)
    v = rng.uniform(-0.3, 0.3, robot.nv)
    v[2] -= 1.0
    named = robot.impact(FEET, q, v)
    cone = robot.impact({f: {"friction": 1000.0} for f in FEET}, q, v)
    assert cone.states == ["stick"] * 4 and named.states == ["stick"] * 4
    assert np.array_equal(cone.v_plus, named.v_plus) and np.array_equal(cone.impulse, named.impulse)


def test_a_pulling_contact_names_contacts(tmp_path):
    """A ball leaving the ground would need a pulling impulse: no Coulomb impact holds it."""
    path = tmp_path / "ball.urdf"
    path.write_text(BALL)
    robot = SpatialRobot.from_urdf(str(path))
    q = robot.neutral()
    q[2] = 0.1
    with pytest.raises(InvalidInputError, match="contacts"):
        robot.impact({"ball": {"radius_m": 0.1, "friction": 0.5}}, q, [0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


def test_lift_off_with_friction_dicts_and_its_bad_type():
    """With ``lift_off`` the dict form with ``friction`` (mu = 1000) has the named (sticking,
    mu = infinity) form's outcomes, feet separating among them, and besides them only
    outcomes with a foot slipping (a receding foot may be caught on the cone's edge); a
    non-bool ``lift_off`` raises ``InvalidTypeError`` naming it."""
    robot = SpatialRobot.from_urdf(QUADRUPED)
    rng = np.random.default_rng(8)
    separated = 0
    for _ in range(6):
        q = robot.neutral()
        q[2] = 0.4
        q[7:] = np.tile([0.0, 0.5, -1.0], 4)
        v = rng.uniform(-1.0, 1.0, robot.nv)
        v[2] -= 0.5
        named = robot.impact_outcomes(FEET, q, v, lift_off=True)
        dicts = robot.impact_outcomes({f: {"friction": 1000.0} for f in FEET}, q, v, lift_off=True)
        without_slip = [o for o in dicts if "slip" not in o.states]
        assert [o.states for o in without_slip] == [o.states for o in named]
        for a, b in zip(without_slip, named):
            assert np.max(np.abs(a.v_plus - b.v_plus)) < 1e-12 * np.max(np.abs(v))
        separated += sum(o.states.count("separate") for o in named)
    assert separated > 0
    for call in (robot.impact, robot.impact_outcomes):
        with pytest.raises(InvalidTypeError) as e:
            call(FEET, robot.neutral(), np.zeros(robot.nv), lift_off="yes")
        assert e.value.field == "lift_off"
