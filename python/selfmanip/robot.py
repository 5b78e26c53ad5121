"""Any planar legged robot loaded from a description (TOML or JSON), and the result types
shared with :mod:`selfmanip.rhex`.

A description has a rigid body, legs as planar serial chains of revolute joints (links may be
massless), foot and body contact shapes, and per-contact friction; see
``tests/data/quadruped.toml`` in the repository for a complete example and
``docs/robot-description.md`` for every field, unit and default. Contact modes are given
by contact names: ``"front_foot,rear_foot"``; append ``:slide`` to let a sticking contact slide
(``"front_foot:slide,rear_foot"``); ``""`` is flight.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from . import _checks
from ._native import Robot as _NativeRobot
from ._wrapped_model import WrappedModel
from .errors import InvalidInputError, InvalidTypeError

if TYPE_CHECKING:
    from .spatial import SpatialRobot


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


@dataclass(frozen=True)
class Kinematics:
    """Forward kinematics at one ``q`` (world frame, NED: x forward, z down; angles about +y,
    nose-up positive). Per joint ``j`` (the order of ``q``): ``joint_positions_m[j]`` is the
    joint's world position (the origin of the link it drives), ``link_angles_rad[j]`` the
    link's world angle (``phi`` plus the joint angles of its chain, with their axis signs) and
    ``link_tips_m[j]`` the far end of the link (the next joint, or the leg's end). The
    velocities are ``None`` unless ``qd`` was given."""

    body_position_m: np.ndarray
    body_angle_rad: float
    joint_positions_m: np.ndarray
    link_angles_rad: np.ndarray
    link_tips_m: np.ndarray
    body_velocity_m_s: np.ndarray | None = None
    body_rate_rad_s: float | None = None
    joint_velocities_m_s: np.ndarray | None = None
    link_rates_rad_s: np.ndarray | None = None
    link_tip_velocities_m_s: np.ndarray | None = None


@dataclass(frozen=True)
class PointJacobian:
    """A material point of the body or a link: its world ``position_m`` (NED), the part's
    world ``angle_rad`` and the ``3 x nq`` ``jacobian``: ``jacobian[:2] @ qd`` is the point's
    world velocity ``(xdot, zdot)``, ``jacobian[2] @ qd`` the part's angular rate."""

    position_m: np.ndarray
    angle_rad: float
    jacobian: np.ndarray


@dataclass(frozen=True)
class ContactPoints:
    """Every contact site against flat ground at one ``q``, in the order of ``names``: the
    contact point (the lowest point of the site's shape; the tip for a point site) in world
    NED ``points_m (c, 2)``, its height above the ground ``gaps_m`` (negative: penetration;
    the touchdown guards), the ground normal into the ground ``normals (c, 2)``, the ``2 x nq``
    Jacobian of the material point there ``jacobians (c, 2, nq)`` (the rows of the constraint
    matrix ``A`` are its projections) and, with ``qd``, that point's velocity
    ``velocities_m_s (c, 2)`` (zero for a sticking contact)."""

    names: list[str]
    points_m: np.ndarray
    gaps_m: np.ndarray
    normals: np.ndarray
    jacobians: np.ndarray
    velocities_m_s: np.ndarray | None = None


#: File endings of robot formats that are not planar descriptions, and what reads them.
_OTHER_FORMATS = {
    ".urdf": "URDF: load it with selfmanip.SpatialRobot.from_urdf(path)",
    ".xml": "URDF or MJCF XML: load a URDF with selfmanip.SpatialRobot.from_urdf(path) (MJCF is not read; "
            "convert it to URDF first)",
    ".mjcf": "MJCF: not read; convert it to URDF and load that with selfmanip.SpatialRobot.from_urdf(path)",
    ".sdf": "SDF: not read; convert it to URDF and load that with selfmanip.SpatialRobot.from_urdf(path)",
}


def description_format(path: str | os.PathLike[str], text: str | None = None, field: str = "path") -> str:
    """``"json"`` for a ``.json`` file, else ``"toml"``; a URDF, MJCF or SDF file (by its
    ending, or XML text) is an :class:`~selfmanip.errors.InvalidInputError` naming ``path``
    that says which reader takes it, not a TOML parse error (``field``: the argument's name)."""
    p = os.fspath(path)
    ext = os.path.splitext(p)[1].lower()
    if ext in _OTHER_FORMATS or (text is not None and text.lstrip().startswith("<")):
        what = _OTHER_FORMATS.get(ext, "XML (URDF or MJCF): load a URDF with selfmanip.SpatialRobot.from_urdf(path)")
        raise InvalidInputError(f"`{field}`: unsupported format for a planar robot description ({p!r} is {what}); "
                                "planar robots are read from .toml and .json descriptions (docs/robot-description.md)",
                                field)
    return "json" if ext == ".json" else "toml"


class Robot(WrappedModel):
    """A planar robot: ``Robot.from_file("robot.toml")``. Picklable and deep-copyable: a copy is
    rebuilt from the same description (or RHex parameters), so it is the same model. ``nq``
    counts the joints and ``x, z, phi``."""

    _native_class = _NativeRobot
    _construct_with = "Robot.from_file / from_toml / from_json, or selfmanip.rhex.Model"

    # -- construction -------------------------------------------------------------------
    @classmethod
    def from_file(cls, path: str | os.PathLike[str]) -> "Robot":
        """Loads a ``.toml`` or ``.json`` description (``docs/robot-description.md``). A URDF
        or MJCF file raises :class:`~selfmanip.errors.InvalidInputError` naming ``path``: a
        URDF is a spatial robot, :meth:`selfmanip.SpatialRobot.from_urdf`."""
        path = os.fspath(path)
        description_format(path)
        text = _checks.read_text_file("path", path)
        return cls(_NativeRobot.from_description(text, description_format(path, text)))

    @staticmethod
    def from_urdf(path: str | os.PathLike[str], base: str = "free_flyer", root_link: str | None = None,
                  frames: Mapping[str, Mapping[str, Any]] | None = None,
                  contacts: Mapping[str, Mapping[str, Any]] | None = None) -> "SpatialRobot":
        """A URDF robot is spatial: :meth:`selfmanip.SpatialRobot.from_urdf` (the same
        arguments; ``base`` ``"free_flyer"``, ``"planar"`` or ``"fixed"``), returning a
        :class:`~selfmanip.SpatialRobot`."""
        from .spatial import SpatialRobot

        return SpatialRobot.from_urdf(path, base, root_link, frames, contacts)

    @classmethod
    def from_dict(cls, description: Mapping[str, Any]) -> "Robot":
        """A robot from a description given as a dict (the form of the JSON file)."""
        if not isinstance(description, Mapping):
            raise InvalidTypeError(f"`description` must be a dict, got {type(description).__name__}",
                                   "description")
        return cls(_NativeRobot.from_description_data(dict(description)))

    def to_dict(self) -> dict[str, Any]:
        """The description as a dict (every field, defaults filled in): ``Robot.from_dict``
        of it is the same robot."""
        return self._native.description_data()

    @classmethod
    def from_toml(cls, text: str) -> "Robot":
        return cls(_NativeRobot.from_description(_checks.text("text", text), "toml"))

    @classmethod
    def from_json(cls, text: str) -> "Robot":
        return cls(_NativeRobot.from_description(_checks.text("text", text), "json"))

    # -- structure ----------------------------------------------------------------------
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
        """``(kinetic, potential)`` energy in J (potential: gravity's ``-m g z`` with z down, plus
        the joint springs' ``k d^2 / 2 + k3 d^4 / 4``)."""
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

    # -- kinematics ---------------------------------------------------------------------
    def forward_kinematics(self, q: Sequence[float], qd: Sequence[float] | None = None) -> Kinematics:
        """World poses of the body, every joint and every link at ``q`` (and their velocities
        at ``qd`` when given)."""
        d = self._native.forward_kinematics(_checks.vector("q", q), None if qd is None else _checks.vector("qd", qd))
        return Kinematics(**d)

    def _part(self, part: str | int | None) -> int | None:
        """``"body"``/``None`` or a joint given by index, by its name (``"fore[0]"``, ``"fore"``
        for a one-link leg), by its coordinate name (``"fore[0]_theta"``) or, on input only, as
        ``"fore_0"``: the part whose frame a point is given in."""
        if part is None or part == "body":
            return None
        if isinstance(part, str):
            names = self.coordinate_names[: self.n_joints]
            joints = [n[: -len("_theta")] for n in names]
            aliases = ["_".join(j[:-1].split("[")) if j.endswith("]") else f"{j}_0" for j in joints]
            for spelling in (names, joints, aliases):
                if part in spelling:
                    return spelling.index(part)
            raise InvalidInputError(f"`part`: unknown part {part!r} (known: body, {', '.join(joints)})", "part")
        return _checks.integer("part", part, 0)

    def jacobian(self, q: Sequence[float], part: str | int | None = "body",
                 point_m: Sequence[float] = (0.0, 0.0)) -> PointJacobian:
        """The point ``point_m`` of ``part`` (``"body"``, or the link driven by a joint given
        by name, ``"fore[1]"`` (also ``"fore[1]_theta"`` or ``"fore_1"``), or index; the point
        in that part's frame: body frame ``(x forward, z down)``, a link's frame with its tip
        at ``(0, length)``) at ``q``: its world
        position and its ``3 x nq`` Jacobian (world ``xdot``, ``zdot``, the part's angular
        rate).

        >>> import selfmanip
        >>> m = selfmanip.rhex.Model({"leg_shape": "stick"})
        >>> toe = m.jacobian([0.0, 0.0, 0.0, -0.17, 0.0], "front_0", (0.0, 0.17))
        >>> toe.position_m.round(3).tolist(), toe.jacobian.shape
        ([0.205, 0.0], (3, 5))
        """
        pt = _checks.vector("point_m", point_m)
        if len(pt) != 2:
            raise InvalidInputError(f"`point_m` must have 2 entries, got {len(pt)}", "point_m")
        d = self._native.jacobian(_checks.vector("q", q), self._part(part), pt)
        return PointJacobian(np.asarray(d["position_m"]), float(d["angle_rad"]), np.asarray(d["jacobian"]))

    def contact_points(self, q: Sequence[float], qd: Sequence[float] | None = None) -> ContactPoints:
        """Every contact site's point, height, normal and Jacobian against flat ground at
        ``q`` (and the point's velocity at ``qd`` when given)."""
        d = self._native.contact_points(_checks.vector("q", q), None if qd is None else _checks.vector("qd", qd))
        return ContactPoints(**d)

    def mode_spec(self, mode: str) -> str:
        """Validates a mode and returns its normal form."""
        return self._native.mode_spec(_checks.text("mode", mode))


