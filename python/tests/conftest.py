import math
import pathlib

import numpy as np
import pytest

import selfmanip

REPO = pathlib.Path(__file__).resolve().parents[2]
QUADRUPED = REPO / "tests" / "data" / "quadruped.toml"

# Table 4.2 planar-pair leg values (2 x the single-leg 0.063 kg, 0.00046 kg m^2)
MASSIVE_LEGS = {"m_l": 0.126, "I_l": 0.00092}

# the hopper of crates/selfmanip-sim/examples/data under hop.toml, dropped 10 cm with its leg
# at the landing pose, moving forward at 0.3 m/s, simulated to tight tolerances (the state
# the sensitivity tests differentiate)
HOPPER_DATA = REPO / "crates" / "selfmanip-sim" / "examples" / "data"
HOPPER, HOP = HOPPER_DATA / "hopper.toml", HOPPER_DATA / "hop.toml"
# every component to the same absolute tolerance: differences of whole runs resolve a
# derivative no better than each run's error
HOPPER_TIGHT = dict(rtol=1e-12, event_tol_s=1e-14, velocity_tolerance="uniform")
HOPPER_Q0 = [0.5, -1.0, 0.0, -(0.1 + 0.4 * math.cos(0.5)), 0.0]
HOPPER_QD0 = [0.0, 0.0, 0.3, 0.5, 0.0]


def gravity_by_finite_differences(robot, q, h=1e-6):
    """N(q) = dV/dq from the engine's potential energy by central differences: a second route
    to the gravity term the dynamics use internally."""
    q = np.asarray(q, dtype=float)
    n = np.zeros_like(q)
    for i in range(len(q)):
        e = np.zeros_like(q)
        e[i] = h
        n[i] = (robot.energy(q + e, 0 * q)[1] - robot.energy(q - e, 0 * q)[1]) / (2 * h)
    return n


def standing_q(theta1, theta2, rho=0.17):
    """Both stick-like toes on the ground with the body level: z = -rho cos(theta) requires
    theta1 = theta2 for phi = 0."""
    assert theta1 == theta2
    return [theta1, theta2, 0.0, -rho * math.cos(theta1), 0.0]


@pytest.fixture(scope="module")
def rhex():
    return selfmanip.rhex.Model()


@pytest.fixture(scope="module")
def rhex_massive():
    return selfmanip.rhex.Model(MASSIVE_LEGS)


@pytest.fixture(scope="module")
def quadruped():
    return selfmanip.Robot.from_file(QUADRUPED)
