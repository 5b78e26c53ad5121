"""The damped slide of a two-link massless chain (docs/singular-transitions.md section 12): a
foot on a chain of two massless links that reaches its friction cone's edge slides on, its
servos' damping fixing the chain's rates, instead of being released and put straight back.

Independent routes: the statics of a massless chain by virtual work -- each joint's servo
torque equals the moment of the ground force about it, ``tau_j = c_j . F`` with the column
``c_j = dp/dtheta_j`` of the foot point taken by central differences of the robot's own
kinematics (``Robot.contact_points``), not from the engine's flow -- and the energy balance
``E1 - E0 = W + W_fr - L`` with the friction work of the sliding feet non-zero."""

import numpy as np
import pytest

import selfmanip
import test_bounder_landing as bounder

MU = 0.3


def massless_legs():
    d = bounder.description()
    for leg in d["legs"]:
        for link in leg["links"]:
            link.update(mass_kg=0.0, inertia_kg_m2=0.0)
    for c in d["contacts"]:
        c["friction"]["mu"] = MU  # Coulomb sliding by default: mu_kinetic = mu
    return selfmanip.Robot.from_dict(d)


def splayed(hip=0.7, knee=-1.4):
    """Servos that push the feet apart from the bounder's crouch: both feet reach their cones."""
    return {"joints": [{"joint": f"{leg}[{k}]", "phases": [
        {"name": "h", "torque": bounder.servo(target, kp=20.0, kd=0.5, limit=None)}]}
        for leg in ("front", "hind") for k, target in ((0, hip), (1, knee))]}


@pytest.fixture(scope="module")
def run():
    robot = massless_legs()
    return robot, selfmanip.simulate(robot, splayed(), bounder.Q0, t_final=0.4)


def test_feet_slide_on_instead_of_chattering(run):
    _, e = run
    assert e.status == "final_time", e.reason
    assert "ss" in e.word, e.word
    # one landing, then each foot's slip: no release and re-touch, no truncation
    assert [ev["kind"] for ev in e.events].count("touchdown") == 1, e.events
    er = e.energy_report()
    assert abs(er.residual_j) < 1e-6, er
    assert er.friction_work_j < -1e-3, er


def test_each_servo_torque_is_the_moment_of_the_ground_force(run):
    robot, e = run
    tr = e.trajectory(dt=2e-3)
    names = tr.q_names
    checked = 0
    for i, mode in enumerate(tr.mode):
        for c, leg in enumerate(("front", "hind")):
            if mode[c] != "s":
                continue
            q = np.array(tr.q[i], dtype=float)
            F = np.asarray(tr.contact_forces_n[i][c], dtype=float)
            if abs(F[0]) < 1e-9:
                # a foot that has just slipped from rest before its friction edge is taken
                # (known gap, docs/singular-transitions.md section 12, limits)
                continue
            moments, torques = [], []
            for k in (0, 1):
                j = names.index(f"{leg}[{k}]_theta")
                h = 1e-6
                up, down = q.copy(), q.copy()
                up[j] += h
                down[j] -= h
                col = (np.asarray(robot.contact_points(up).points_m[c]) -
                       np.asarray(robot.contact_points(down).points_m[c])) / (2 * h)
                moments.append(float(col @ F))
                torques.append(float(tr.tau[i][j]))
            scale = max(abs(torques[0]), abs(torques[1]), 1e-3)
            # virtual work of the massless chain: tau_j + c_j . F = 0 for both joints
            assert torques[0] == pytest.approx(-moments[0], abs=1e-4 * scale)
            assert torques[1] == pytest.approx(-moments[1], abs=1e-4 * scale)
            checked += 1
    assert checked > 20
