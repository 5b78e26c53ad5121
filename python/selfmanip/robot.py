"""Any planar legged robot loaded from a description (TOML or JSON), and the result types
shared with :mod:`selfmanip.rhex`.

A description has a rigid body, legs as planar serial chains of revolute joints (links may be
massless), foot and body contact shapes, and per-contact friction; see
``tests/data/quadruped.toml`` in the repository for a complete example. Contact modes are given
by contact names: ``"front_foot,rear_foot"``; append ``:slide`` to let a sticking contact slide
(``"front_foot:slide,rear_foot"``); ``""`` is flight.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np

from . import _checks
from ._native import Robot as _NativeRobot


@dataclass(frozen=True)
class Dynamics:
    """Thesis (5.3)-(5.4) at one state.

    ``qdd``: generalized accelerations (length ``nq``). A massless leg out of contact has no
    dynamics (thesis 5.1.1): its joint acceleration is *prescribed*, not computed -- it reports
    ``free_joint_qdd`` (0 unless given), and its torque does no work. ``free_joints`` lists
    those joint indices.
    ``lam``: contact forces, rows as in ``rows`` (``(contact, "tangential"|"normal")``).
    """

    qdd: np.ndarray
    lam: np.ndarray
    rows: list[tuple[str, str]]
    free_joints: list[int]
    mode: str


@dataclass(frozen=True)
class KktBlocks:
    """The blocks of ``[[M, A^T], [A, 0]]^-1 = [[M_dagger, A_dagger^T], [A_dagger, Lambda]]``
    (thesis 5.2), the constraint matrix ``A`` and mass matrix ``M`` (4.25) in full coordinates.
    Rows/columns of free massless joints (not in ``dynamic_coords``) are zero in ``m_dagger`` and
    ``a_dagger``. ``Lambda`` is negative semi-definite (definite when ``M`` is invertible; the
    thesis text says positive). Iterating yields ``m_dagger, a_dagger,
    Lambda, A``."""

    m_dagger: np.ndarray
    a_dagger: np.ndarray
    Lambda: np.ndarray
    A: np.ndarray
    M: np.ndarray
    rows: list[tuple[str, str]]
    dynamic_coords: list[int]
    constraint_condition: float
    reduced_mass_condition: float

    def __iter__(self):
        return iter((self.m_dagger, self.a_dagger, self.Lambda, self.A))


@dataclass(frozen=True)
class Impact:
    """Plastic impact (5.10)/(5.52): post-impact velocity and the contact impulse (same sign
    convention as ``lam``)."""

    qd_plus: np.ndarray
    impulse: np.ndarray
    rows: list[tuple[str, str]]


@dataclass(frozen=True)
class QuasiStatic:
    """Quasi-static contact forces (4.21)-(4.23) in the robot-pushes-ground convention ``f``
    (``lam = -f``): grasp map ``G_s`` (3 x c), hand Jacobian ``J_h`` (c x n), internal forces
    ``ker G_s`` and the torques they need, and the particular solution."""

    G_s: np.ndarray
    J_h: np.ndarray
    internal_basis: np.ndarray
    internal_torques: np.ndarray
    f_particular: np.ndarray
    lam_particular: np.ndarray
    tau_particular: np.ndarray
    gravity_wrench: list[float]


class Robot:
    """A planar robot: ``Robot.from_file("robot.toml")``."""

    def __init__(self, native: _NativeRobot):
        if not isinstance(native, _NativeRobot):
            raise TypeError("use Robot.from_file / from_toml / from_json, or selfmanip.rhex.Model")
        self._native = native

    # -- construction -------------------------------------------------------------------
    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> "Robot":
        """Loads a ``.toml`` or ``.json`` description."""
        path = os.fspath(path)
        fmt = "json" if path.endswith(".json") else "toml"
        with open(path, encoding="utf-8") as f:
            return cls(_NativeRobot.from_description(f.read(), fmt))

    @classmethod
    def from_toml(cls, text: str) -> "Robot":
        return cls(_NativeRobot.from_description(_checks.text("text", text), "toml"))

    @classmethod
    def from_json(cls, text: str) -> "Robot":
        return cls(_NativeRobot.from_description(_checks.text("text", text), "json"))

    # -- structure ----------------------------------------------------------------------
    @property
    def name(self) -> str:
        return self._native.name

    @property
    def nq(self) -> int:
        """Number of generalized coordinates (joints + x, z, phi)."""
        return self._native.nq

    @property
    def n_joints(self) -> int:
        return self._native.n_joints

    @property
    def contact_names(self) -> list[str]:
        return list(self._native.contact_names)

    @property
    def coordinate_names(self) -> list[str]:
        return list(self._native.coordinate_names)

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, nq={self.nq}, contacts={self.contact_names})"

    # -- dynamics -----------------------------------------------------------------------
    def dynamics(
        self,
        mode: str,
        q: Sequence[float],
        qd: Sequence[float],
        tau: Sequence[float],
        free_joint_qdd: Sequence[float] | None = None,
    ) -> Dynamics:
        """Constrained dynamics (5.3)-(5.4) in ``mode`` at ``(q, qd)`` under joint torques
        ``tau`` (N m, length ``n_joints``)."""
        fj = None if free_joint_qdd is None else _checks.vector("free_joint_qdd", free_joint_qdd)
        d = self._native.dynamics(
            _checks.text("mode", mode),
            _checks.vector("q", q),
            _checks.vector("qd", qd),
            _checks.vector("tau", tau),
            fj,
        )
        return Dynamics(d["qdd"], d["lam"], [tuple(r) for r in d["rows"]], list(d["free_joints"]), d["mode"])

    def kkt(self, mode: str, q: Sequence[float]) -> KktBlocks:
        """The mass-weighted inverses ``M_dagger, A_dagger, Lambda`` (5.2) and ``A`` at ``q``."""
        d = self._native.kkt(_checks.text("mode", mode), _checks.vector("q", q))
        d["rows"] = [tuple(r) for r in d["rows"]]
        return KktBlocks(**d)

    def impact(self, mode: str, q: Sequence[float], qd_minus: Sequence[float]) -> Impact:
        """Plastic impact into ``mode`` (5.10)."""
        d = self._native.impact(_checks.text("mode", mode), _checks.vector("q", q), _checks.vector("qd_minus", qd_minus))
        return Impact(d["qd_plus"], d["impulse"], [tuple(r) for r in d["rows"]])

    def energy(self, q: Sequence[float], qd: Sequence[float]) -> tuple[float, float]:
        """``(kinetic, potential)`` energy in J (potential with z down: ``-m g z``)."""
        return self._native.energy(_checks.vector("q", q), _checks.vector("qd", qd))

    def contact_gaps(self, q: Sequence[float]) -> dict[str, float]:
        """Height of each contact site above flat ground (m; negative = penetration): the
        touchdown guard functions."""
        return dict(self._native.contact_gaps(_checks.vector("q", q)))

    def quasi_static(
        self, mode: str, q: Sequence[float], torque_constraints: Sequence[Sequence[float]] = ()
    ) -> QuasiStatic:
        """Quasi-static forces (4.21)-(4.23); ``torque_constraints`` are the rows ``t`` of
        ``t^T tau = 0`` (each of length ``n_joints``; as many as contact rows minus 3)."""
        rows = [_checks.vector(f"torque_constraints[{i}]", t) for i, t in enumerate(torque_constraints)]
        d = self._native.quasi_static(_checks.text("mode", mode), _checks.vector("q", q), rows)
        return QuasiStatic(**d)

    def mode_spec(self, mode: str) -> str:
        """Validates a mode and returns its normal form."""
        return self._native.mode_spec(_checks.text("mode", mode))


