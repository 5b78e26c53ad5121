"""MuJoCo (``pip install mujoco``, in the test extra) as a second independent route, beside
Pinocchio: the same robots written for MuJoCo's own compiler and dynamics.

- **Planar robots** (the core's sagittal-plane model, the path a user's ``simulate`` runs): a
  description is written as MJCF — the body on MuJoCo's slide ``x``, slide ``z``, hinge ``y``,
  each link a body on a hinge — with NED mapped to MuJoCo's z-up world (``x`` the same,
  ``z_mj = −z``, a rotation about the NED ``+y`` one about MuJoCo's ``−y``). Link centres of
  mass off the link's axis, both joint senses, armature, joint springs and dampers (MuJoCo's
  ``armature``, ``stiffness``/``springref``, ``damping``), and gravity's magnitude are
  carried over field by field. In flight ``q̈`` is MuJoCo's ``qacc`` (contacts off), and the
  kinetic and potential energies its ``mj_energyVel``/``mj_energyPos``; with both feet
  sticking, ``q̈`` and the feet's forces (as generalized forces) solve the KKT system of MuJoCo's ``M``, bias forces,
  passive forces and the feet's Jacobians (``mj_jac``) and drifts (``mj_jacDot``).
- **Spatial robots**: the shipped quadruped URDF read by MuJoCo's own URDF compiler, on a
  free joint (MuJoCo's free-joint velocity is ``[v_world, ω_body]``, Pinocchio's and ours
  ``[v_body, ω_body]``: ``v = T v_mj`` with ``T = diag(Rᵀ, 1…)``, so ``M_mj = Tᵀ M T`` and
  ``h_mj = Tᵀ (h + M Ṫ v_mj)``, ``Ṫ v_mj = [−ω × v_lin; 0]``) and fixed.

Massless links are the engine's and not MuJoCo's (its compiler refuses a moving body without
mass): the robots here are massive throughout."""

from __future__ import annotations

import math
import pathlib

import numpy as np
import pytest

import selfmanip
from selfmanip import SpatialRobot

mujoco = pytest.importorskip("mujoco", reason="MuJoCo (`pip install mujoco`, in the test extra) is a second independent route")

URDF = pathlib.Path(__file__).resolve().parents[2] / "tests" / "data" / "urdf" / "quadruped12.urdf"


def bounder(rng: np.random.Generator | None = None) -> dict:
    """The newcomer's bounder of issue 30 (2 kg body, two two-link legs, point feet), its
    shins massive; with ``rng``, a variant with every field MuJoCo carries drawn at random:
    gravity, masses and inertias, hips, lengths, centres of mass off the link's axis, joint
    senses, armature and joint springs with dampers."""
    legs = []
    for name, hip_x in (("front", 0.2), ("hind", -0.2)):
        links = []
        for i in range(2):
            link = {"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4}
            if rng is not None:
                length = float(rng.uniform(0.08, 0.25))
                link = {"length_m": length, "mass_kg": float(rng.uniform(0.05, 0.5)),
                        "inertia_kg_m2": float(rng.uniform(1e-5, 1e-3)),
                        "com_m": [float(rng.uniform(-0.02, 0.02)), float(rng.uniform(0.2, 0.8) * length)],
                        "axis": str(rng.choice(["+y", "-y"])),
                        "armature_kg_m2": float(rng.choice([0.0, rng.uniform(1e-4, 1e-2)]))}
                if rng.uniform() < 0.5:
                    link["spring"] = {"stiffness_n_m_per_rad": float(rng.uniform(0, 20)),
                                      "damping_n_m_s_per_rad": float(rng.uniform(0, 0.5)),
                                      "rest_angle_rad": float(rng.uniform(-1, 1))}
            links.append(link)
        hip = [hip_x, 0.0] if rng is None else [float(hip_x + rng.uniform(-0.05, 0.05)), float(rng.uniform(-0.03, 0.03))]
        legs.append({"name": name, "hip_m": hip, "links": links})
    feet = [{"name": f"{leg['name']}_foot", "leg": leg["name"],
             "shape": {"kind": "point", "position_m": [0.0, leg["links"][-1]["length_m"]]},
             "friction": {"kind": "sticking", "mu": 0.8}} for leg in legs]
    body = {"mass_kg": 2.0, "inertia_kg_m2": 0.0267}
    robot = {"name": "bounder", "body": body, "contacts": feet, "legs": legs}
    if rng is not None:
        body.update(mass_kg=float(rng.uniform(1, 5)), inertia_kg_m2=float(rng.uniform(0.01, 0.1)))
        robot["gravity_m_s2"] = float(rng.uniform(1.6, 9.81))
    return robot


def _inertial(mass: float, inertia: float, com_ned: tuple[float, float]) -> str:
    # only I_yy enters a motion in the x-z plane; the others keep MuJoCo's triangle inequality
    x, z = com_ned
    return f'<inertial pos="{x!r} 0 {-z!r}" mass="{mass!r}" diaginertia="{inertia!r} {inertia!r} {inertia!r}"/>'


def mjcf(robot: dict) -> str:
    """The planar ``robot`` as MJCF in MuJoCo's z-up world (module docs)."""
    def link_bodies(leg: dict) -> str:
        xml, close = "", ""
        pos = (leg["hip_m"][0], leg["hip_m"][1])
        for i, link in enumerate(leg["links"]):
            axis = "0 -1 0" if link.get("axis", "+y") == "+y" else "0 1 0"
            length = link["length_m"]
            com = link.get("com_m") or [0.0, length / 2]
            spring = link.get("spring") or {}
            joint = (f'<joint name="{leg["name"]}[{i}]" type="hinge" axis="{axis}" '
                     f'armature="{link.get("armature_kg_m2", 0.0)!r}" '
                     f'stiffness="{spring.get("stiffness_n_m_per_rad", 0.0)!r}" '
                     f'springref="{spring.get("rest_angle_rad", 0.0)!r}" '
                     f'damping="{spring.get("damping_n_m_s_per_rad", 0.0)!r}"/>')
            xml += (f'<body name="{leg["name"]}_{i}" pos="{pos[0]!r} 0 {-pos[1]!r}">{joint}'
                    + _inertial(link["mass_kg"], link["inertia_kg_m2"], com)
                    + f'<site name="{leg["name"]}_{i}_end" pos="0 0 {-length!r}"/>')
            close += "</body>"
            pos = (0.0, length)
        return xml + close

    body = robot["body"]
    g = robot.get("gravity_m_s2", 9.81)
    return f"""<mujoco>
  <compiler angle="radian"/>
  <option gravity="0 0 {-g!r}"><flag contact="disable" energy="enable"/></option>
  <worldbody><body name="body">
    <joint name="x" type="slide" axis="1 0 0"/><joint name="z" type="slide" axis="0 0 1"/>
    <joint name="phi" type="hinge" axis="0 -1 0"/>
    {_inertial(body["mass_kg"], body["inertia_kg_m2"], (0.0, 0.0))}
    {"".join(link_bodies(leg) for leg in robot["legs"])}
  </body></worldbody>
</mujoco>"""


class Planar:
    """A planar robot in both engines, with its coordinates mapped between them."""

    def __init__(self, robot: dict):
        self.ours = selfmanip.Robot.from_dict(robot)
        self.model = mujoco.MjModel.from_xml_string(mjcf(robot))
        self.data = mujoco.MjData(self.model)
        # a joint's coordinate is named `<joint>_theta`, the body's `x`, `z`, `phi`
        names = [n.removesuffix("_theta") for n in self.ours.coordinate_names]
        # our coordinate i is MuJoCo's dof `index[i]` times `sign[i]` (z is flipped)
        self.index = [self.model.joint(n).dofadr[0] for n in names]
        self.sign = np.array([-1.0 if n == "z" else 1.0 for n in names])
        self.n_joints = self.ours.n_joints

    def to_mujoco(self, x: np.ndarray) -> np.ndarray:
        out = np.zeros(self.model.nv)
        out[self.index] = self.sign * x
        return out

    def from_mujoco(self, x: np.ndarray) -> np.ndarray:
        return self.sign * x[self.index]

    def forward(self, q, qd, tau) -> None:
        d = self.data
        d.qpos[:] = self.to_mujoco(q)  # every joint has one coordinate: qpos is laid out as qvel
        d.qvel[:] = self.to_mujoco(qd)
        d.qfrc_applied[:] = self.to_mujoco(np.concatenate([tau, np.zeros(3)]))
        mujoco.mj_forward(self.model, d)


def full_mass_matrix(m, d) -> np.ndarray:
    """MuJoCo's ``M`` in full (``mj_fullM`` takes the data since MuJoCo 3.3, its ``qM`` before)."""
    M = np.zeros((m.nv, m.nv))
    try:
        mujoco.mj_fullM(m, d, M)
    except TypeError:
        mujoco.mj_fullM(m, M, d.qM)
    return M


def random_state(p: Planar, rng: np.random.Generator):
    n = p.n_joints
    q = np.concatenate([rng.uniform(-1.5, 1.5, n), [rng.uniform(-1, 1), rng.uniform(-1, 0), rng.uniform(-1, 1)]])
    qd = rng.normal(scale=2.0, size=n + 3)
    tau = rng.normal(scale=2.0, size=n)
    return q, qd, tau


ROBOTS = {"bounder": bounder()} | {f"random_{s}": bounder(np.random.default_rng(s)) for s in range(6)}


@pytest.mark.parametrize("name", list(ROBOTS))
def test_a_planar_robot_in_flight_is_mujocos(name):
    p = Planar(ROBOTS[name])
    rng = np.random.default_rng(11)
    for _ in range(4):
        q, qd, tau = random_state(p, rng)
        p.forward(q, qd, tau)
        qdd = p.ours.dynamics("", q, qd, tau).qdd
        expected = p.from_mujoco(p.data.qacc)
        assert np.allclose(qdd, expected, rtol=0, atol=1e-10 * max(1.0, np.abs(expected).max())), (qdd, expected)
        # the energies: MuJoCo's potential is gravity's m g z_mj plus its springs'
        mujoco.mj_energyPos(p.model, p.data)
        mujoco.mj_energyVel(p.model, p.data)
        kinetic, potential = p.ours.energy(q, qd)
        assert math.isclose(kinetic, p.data.energy[1], rel_tol=1e-12, abs_tol=1e-12)
        assert math.isclose(potential, p.data.energy[0], rel_tol=1e-12, abs_tol=1e-12)


@pytest.mark.parametrize("name", list(ROBOTS))
def test_a_planar_robot_on_both_feet_solves_mujocos_kkt_system(name):
    # both feet sticking: M q̈ + h = τ + Jᵀ f, J q̈ + J̇ q̇ = 0, in MuJoCo's coordinates, with
    # the feet's world x, z rows of mj_jac at the link ends and h = bias − passive forces
    p = Planar(ROBOTS[name])
    m, d = p.model, p.data
    rng = np.random.default_rng(12)
    for _ in range(4):
        q, qd, tau = random_state(p, rng)
        p.forward(q, qd, tau)
        M = full_mass_matrix(m, d)
        rows, drift = [], []
        for leg in ROBOTS[name]["legs"]:
            site = m.site(f"{leg['name']}_{len(leg['links']) - 1}_end")
            jacp, jacp_dot = np.zeros((3, m.nv)), np.zeros((3, m.nv))
            mujoco.mj_jac(m, d, jacp, None, d.site_xpos[site.id], m.site_bodyid[site.id])
            mujoco.mj_jacDot(m, d, jacp_dot, None, d.site_xpos[site.id], m.site_bodyid[site.id])
            rows += [jacp[0], jacp[2]]
            drift += [jacp_dot[0] @ d.qvel, jacp_dot[2] @ d.qvel]
        J, c = np.array(rows), len(rows)
        kkt = np.block([[M, -J.T], [J, np.zeros((c, c))]])
        rhs = np.concatenate([d.qfrc_applied - d.qfrc_bias + d.qfrc_passive, -np.array(drift)])
        solution = np.linalg.solve(kkt, rhs)
        expected = p.from_mujoco(solution[: m.nv])
        ours = p.ours.dynamics("front_foot,hind_foot", q, qd, tau)
        assert np.allclose(ours.qdd, expected, rtol=0, atol=1e-9 * max(1.0, np.abs(expected).max())), (ours.qdd, expected)
        # the feet's forces as generalized forces, whatever the rows' frames: ours enter
        # M q̈ + h + Aᵀλ = τ (thesis (5.2)), MuJoCo's as + Jᵀ f
        A = np.asarray(p.ours.kkt("front_foot,hind_foot", q).A)
        generalized = p.from_mujoco(J.T @ solution[m.nv:])
        assert np.allclose(-A.T @ ours.lam, generalized, rtol=0, atol=1e-9 * max(1.0, np.abs(generalized).max()))


def test_the_quadruped_urdf_in_mujocos_compiler_has_our_mass_matrix_and_bias_forces():
    ours = SpatialRobot.from_urdf(URDF)
    spec = mujoco.MjSpec.from_file(str(URDF))
    spec.worldbody.first_body().add_freejoint()
    m = spec.compile()
    d = mujoco.MjData(m)
    assert math.isclose(float(m.body_subtreemass[0]), ours.total_mass, rel_tol=1e-14)
    fixed = SpatialRobot.from_urdf(URDF, base="fixed")
    m_fixed = mujoco.MjModel.from_xml_path(str(URDF))
    d_fixed = mujoco.MjData(m_fixed)
    rng = np.random.default_rng(5)
    for _ in range(4):
        q = ours.neutral()
        q[:3] = rng.normal(size=3)
        quat = rng.normal(size=4)
        q[3:7] = quat / np.linalg.norm(quat)
        q[7:] = rng.uniform(-1.0, 1.0, size=ours.nq - 7)
        v = rng.normal(size=ours.nv)
        # MuJoCo's free joint: [x y z qw qx qy qz], velocity [v_world, ω_body]
        d.qpos[:3] = q[:3]
        d.qpos[3:7] = [q[6], q[3], q[4], q[5]]
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, d.qpos[3:7])
        R = R.reshape(3, 3)
        d.qvel[:3] = R @ v[:3]
        d.qvel[3:6] = v[3:6]
        T = np.zeros((ours.nv, m.nv))
        T[:3, :3] = R.T
        T[3:6, 3:6] = np.eye(3)
        for i, name in enumerate(ours.joint_names[1:]):
            j = m.joint(name)
            d.qpos[j.qposadr[0]] = q[7 + i]
            d.qvel[j.dofadr[0]] = v[6 + i]
            T[6 + i, j.dofadr[0]] = 1.0
        mujoco.mj_forward(m, d)
        M_mj = full_mass_matrix(m, d)
        M = ours.mass_matrix(q)
        Tdot_v = np.concatenate([-np.cross(v[3:6], v[:3]), np.zeros(ours.nv - 3)])
        assert np.abs(T.T @ M @ T - M_mj).max() < 1e-12 * np.abs(M_mj).max()
        h = T.T @ (ours.bias_forces(q, v) + M @ Tdot_v)
        assert np.abs(h - d.qfrc_bias).max() < 1e-12 * np.abs(d.qfrc_bias).max()
        # on a fixed base the layouts are the same but for MuJoCo's joint order
        dof = [m_fixed.joint(n).dofadr[0] for n in fixed.joint_names]
        d_fixed.qpos[dof] = q[7:]
        d_fixed.qvel[dof] = v[6:]
        mujoco.mj_forward(m_fixed, d_fixed)
        M_fixed = full_mass_matrix(m_fixed, d_fixed)
        assert np.abs(fixed.mass_matrix(q[7:]) - M_fixed[np.ix_(dof, dof)]).max() < 1e-12 * np.abs(M_fixed).max()
        h_fixed = fixed.bias_forces(q[7:], v[6:])
        assert np.abs(h_fixed - d_fixed.qfrc_bias[dof]).max() < 1e-12 * np.abs(d_fixed.qfrc_bias).max()
