"""Events and coordinates in the one convention of every output (``docs/conventions.md``).

* An event carries the contact force right after it (``force_n``) and, only when it is an
  impact, its impulse (``impulse_n_s``): per contact site in the description's order, world NED
  ``[x, z]``, the ground's action on the robot. Checked against closed forms: a level block
  dropped from rest through ``h`` lands at ``v = g t`` (``t = sqrt(2h/g)``), so its plastic
  impact on two frictionless corners takes the vertical momentum ``m v`` (``sum p_z = -m v``,
  no ``x`` impulse, half at each corner by symmetry), and at rest after it the corners carry
  its weight (``sum f_z = -m g``); a block sliding on Coulomb corners sticks with no impulse
  and carries its weight at rest.
* Coordinate names: ``Robot.coordinate_names``, ``Execution.q_names`` and a trajectory's
  ``q_names`` are one spelling, and ``Robot.jacobian`` takes a joint by any accepted spelling.
"""
from __future__ import annotations

import json
import math
import pathlib

import numpy as np
import pytest

import selfmanip

ROOT = pathlib.Path(__file__).resolve().parents[2]
BLOCK = ROOT / "tests" / "data" / "robots" / "block_on_two_feet.toml"
QUAD = ROOT / "crates" / "selfmanip-sim" / "examples" / "data" / "quadruped.toml"
G = 9.81


def _none_or_pair(sites: list, n: int) -> None:
    assert len(sites) == n
    for s in sites:
        assert s is None or (len(s) == 2 and all(math.isfinite(v) for v in s))


def test_a_landing_impulse_is_the_momentum_it_stops_and_the_force_after_is_the_weight():
    h, m = 0.3, 2.0
    robot = selfmanip.Robot.from_file(BLOCK)
    e = selfmanip.simulate(robot, None, [0.0, -(h + 0.05), 0.0], t_final=0.5)
    (land,) = e.events
    assert land["kind"] == "touchdown"
    n = len(robot.contact_names)
    _none_or_pair(land["impulse_n_s"], n)
    _none_or_pair(land["force_n"], n)
    p = np.array(land["impulse_n_s"], dtype=float)
    v = G * math.sqrt(2 * h / G)
    assert p[:, 1].sum() == pytest.approx(-m * v, rel=1e-9)
    np.testing.assert_allclose(p[:, 0], 0.0, atol=1e-12)
    assert p[0, 1] == pytest.approx(p[1, 1], rel=1e-9)
    f = np.array(land["force_n"], dtype=float)
    assert f[:, 1].sum() == pytest.approx(-m * G, rel=1e-9)
    np.testing.assert_allclose(f[:, 0], 0.0, atol=1e-9)
    # the same presentation as the trajectory's samples after the landing
    tr = e.trajectory(0.05)
    assert tr.contacts == robot.contact_names
    np.testing.assert_allclose(tr.contact_forces_n[-1], f, rtol=1e-9, atol=1e-9)
    # plain data: JSON round-trips it
    assert json.loads(json.dumps(e.events)) == e.events


def test_a_stick_carries_a_force_and_no_impulse():
    m, mu, v0 = 2.0, 0.3, 0.9
    text = BLOCK.read_text().replace('{ kind = "sliding" }', f'{{ kind = "sticking", mu = {mu}, mu_kinetic = {mu} }}')
    robot = selfmanip.Robot.from_toml(text)
    e = selfmanip.simulate(robot, None, [0.0, -0.05, 0.0], [v0, 0.0, 0.0], t_final=0.5,
                           contacts="front_corner:slide,rear_corner:slide")
    stick = [ev for ev in e.events if ev["kind"] == "stick"]
    assert stick
    for ev in stick:
        assert ev["impulse_n_s"] == [None, None]
        f = np.array(ev["force_n"], dtype=float)
        # at rest on both corners: the weight, no friction left
        assert f[:, 1].sum() == pytest.approx(-m * G, rel=1e-9)
        np.testing.assert_allclose(f[:, 0], 0.0, atol=1e-9)


def test_the_mcap_events_hold_the_same_records(tmp_path):
    from mcap.reader import make_reader

    e = selfmanip.simulate(BLOCK, None, [0.0, -0.35, 0.0], t_final=0.5)
    path = e.to_mcap(tmp_path / "block.mcap", dt=0.05)
    with open(path, "rb") as f:
        got = [json.loads(msg.data) for _s, ch, msg in make_reader(f).iter_messages() if ch.topic == "/events"]
    assert got == e.events


def test_coordinate_names_are_one_spelling_in_every_output():
    robot = selfmanip.Robot.from_file(QUAD)
    q0 = [0.5, -1.0, 0.5, -1.0, 0.0, -0.5, 0.0]
    e = selfmanip.simulate(robot, None, q0, t_final=0.01)
    names = robot.coordinate_names
    assert names == e.q_names == e.trajectory(0.005).q_names
    assert names[-3:] == ["x", "z", "phi"]
    joints = [n[: -len("_theta")] for n in names[: robot.n_joints]]
    assert all(n.endswith("_theta") for n in names[: robot.n_joints])
    q = np.array(q0)
    for j, joint in enumerate(joints):
        leg, _, i = joint.rstrip("]").partition("[")
        alias = f"{leg}_{i or 0}"
        want = robot.jacobian(q, j, (0.0, 0.1))
        for part in (joint, f"{joint}_theta", alias):
            got = robot.jacobian(q, part, (0.0, 0.1))
            np.testing.assert_array_equal(got.jacobian, want.jacobian)
    with pytest.raises(selfmanip.errors.InvalidInputError, match="part"):
        robot.jacobian(q, "no_such_joint", (0.0, 0.1))
