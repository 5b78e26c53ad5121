"""Spatial robots (d = 3) from URDF: kinematics, mass matrix, bias forces, and the constrained
dynamics and plastic impact of point contacts, exact when links are massless (issue 32,
part 1).

Conventions (Pinocchio's, so arrays pass between the two unchanged): the world is URDF's, z
up, gravity ``[0, 0, -9.81]``; a free-flying base has ``q = [x, y, z, qx, qy, qz, qw, joints...]``
(unit quaternion) and ``v = [v_lin, omega, joint rates...]`` with the base twist in the
**base frame**, so ``nq = nv + 1``; a planar base (``base="planar"``) moves in the world's
``x``-``z`` plane with ``q = [x, z, theta, joints...]`` and ``v = dq/dt`` (``theta`` the turn
about ``y``; Pinocchio's composite root joint of ``PX``, ``PZ``, ``RY``), and its contacts
with friction hold no force across the plane (rows ``[t, n]``, ``t`` the world ``x`` on flat
ground); joints are ordered depth first over the URDF tree as in Pinocchio; Jacobians are
``6 x nv`` with the linear rows first. Contacts are frame names:
``"FL_foot"`` constrains three rows (world ``x``, ``y``, ``z`` on flat ground: two tangents,
then the normal), ``"FL_foot:frictionless"`` the normal only; ``lam`` is the ground's force on
the robot along those rows (a pushing normal force is positive), with
``M qdd + h = tau + A^T lam``.

A contact may be any frame, including frames added to the URDF's with
``from_urdf(path, frames={name: {"parent": frame, "xyz_m": [..], "rpy_rad": [..]}})`` (a flat
foot's corners). Contacts may also be a dict ``{frame: {"radius_m": r, "friction": mu}}``: a point (``r = 0``)
or a sphere foot of radius ``r`` about the frame's origin, with three rows if ``mu > 0`` (and
in ``impact`` Coulomb's circular cone of ``mu``: each contact sticks inside it or slips on its
edge) and the normal row alone if ``mu = 0``; ``"slide": True`` keeps the normal row and applies Coulomb
friction ``mu`` on the circular cone's edge against the contact point's sliding velocity;
``"normal": [nx, ny, nz]`` tilts the ground; and an arc of radius ``r`` is
``"arc": {"axis": [..], "zero": [..], "angle_range_rad": [a, b]}`` (frame axes: the arc spans
the angles ``a..b`` about ``axis`` from the direction ``zero``; RHex's C-leg is the arc of
radius 0.085 about ``..._arc`` with axis ``[0, -1, 0]``, zero ``[0, 0, -1]`` and range
``[0, pi]``). A bad entry raises ``InvalidInputError`` naming ``contacts[frame].key``.
Contacts declared once, ``from_urdf(path, contacts={frame: {...}})`` (or
``selfmanip.Robot.from_urdf``), are then named by a mode string of one ``0``/``1`` per declared
contact (``robot.dynamics("1011", q, v, tau)``), a list of declared names, or ``None`` (all).

Example::

    robot = SpatialRobot.from_urdf("tests/data/urdf/quadruped12.urdf")
    q, v = robot.neutral(), np.zeros(robot.nv)
    out = robot.dynamics(["FL_foot", "FR_foot", "HL_foot", "HR_foot"], q, v, np.zeros(robot.nv))
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Any, Literal, Mapping, Sequence

import numpy as np

from ._native import SpatialRobot as _NativeSpatialRobot
from ._wrapped_model import WrappedModel
from .errors import InvalidInputError, InvalidTypeError

ReferenceFrame = Literal["local", "world", "local_world_aligned"]
Contacts = Sequence[str] | Mapping[str, Mapping[str, Any]] | str | None


@dataclass(frozen=True)
class SpatialDynamics:
    """Constrained forward dynamics (thesis 5.3-5.4) at one state: ``qdd`` (nv), ``lam`` (one
    entry per row of ``rows``: ``(frame, "t1" | "t2" | "n")``), the contact Jacobian ``A`` and
    its drift ``A_dot v`` with ``A qdd + drift = 0``."""

    qdd: np.ndarray
    lam: np.ndarray
    rows: list[tuple[str, str]]
    A: np.ndarray
    drift: np.ndarray


@dataclass(frozen=True)
class SpatialKkt:
    """The blocks of the KKT inverse (thesis 5.2) of a contact set: ``[M A^T; A 0]^-1 =
    [M_dagger A_dagger^T; A_dagger Lambda]``, exact for a singular ``M`` (Lemma 5.1), with the
    system's ``A`` and ``M``. In this module's sign (``M qdd + h = tau + A^T lam``):
    ``qdd = M_dagger (tau - h) - A_dagger^T drift`` and ``lam = -A_dagger (tau - h) + Lambda
    drift``. The ``free_rates`` of a massless limb in the air are left out (zero rows and
    columns); ``constraint_condition`` and ``reduced_mass_condition`` are the factorization's
    condition numbers of the rows and of the motion they leave free. Iterating yields
    ``m_dagger, a_dagger, Lambda, A``, as the planar robots' ``kkt``."""

    m_dagger: np.ndarray
    a_dagger: np.ndarray
    Lambda: np.ndarray
    A: np.ndarray
    M: np.ndarray
    rows: list[tuple[str, str]]
    free_rates: list[int]
    constraint_condition: float
    reduced_mass_condition: float

    def __iter__(self):
        return iter((self.m_dagger, self.a_dagger, self.Lambda, self.A))


@dataclass(frozen=True)
class SpatialImpact:
    """Plastic impact (thesis 5.10): ``v_plus`` (nv) with every held contact's normal velocity
    zero and the ground's impulse on the robot along ``rows``; each contact's ``states`` entry
    is ``"stick"`` (every row held), ``"slip"`` (the impulse on its friction cone's edge,
    opposite its slip after), ``"frictionless"`` or, with ``lift_off``, ``"separate"`` (no
    impulse, leaving the ground)."""

    v_plus: np.ndarray
    impulse: np.ndarray
    rows: list[tuple[str, str]]
    states: list[str]


@dataclass(frozen=True)
class SpatialQuasiStatic:
    """Quasi-static forces at rest (thesis 4.21-4.22): the grasp map ``grasp`` (b x c, the
    contact rows' base columns transposed; b = 6 on a free-flying base, 3 on a planar one),
    the base's gravity wrench ``gravity_wrench`` with ``grasp @ lam = gravity_wrench``; the
    minimum-norm external forces ``lam_external`` and an orthonormal basis ``internal_basis`` of
    the internal forces (``ker grasp``); the joint torques ``tau_external`` that hold
    ``lam_external`` and ``internal_torques`` of each internal force."""

    grasp: np.ndarray
    gravity_wrench: np.ndarray
    lam_external: np.ndarray
    internal_basis: np.ndarray
    tau_external: np.ndarray
    internal_torques: np.ndarray
    rows: list[tuple[str, str]]


def _vector(x: np.ndarray | Sequence[float]) -> np.ndarray:
    return np.ascontiguousarray(x, dtype=float).reshape(-1)


class SpatialRobot(WrappedModel):
    """A spatial robot: ``SpatialRobot.from_urdf(path, base="free_flyer")``. Picklable and
    deep-copyable: a copy is rebuilt from the same URDF text, base and root link."""

    _native_class = _NativeSpatialRobot
    _construct_with = "SpatialRobot.from_urdf"

    _declared: dict[str, dict[str, Any]] = {}

    @classmethod
    def from_urdf(cls, path: str | os.PathLike[str], base: Literal["free_flyer", "planar", "fixed"] = "free_flyer",
                  root_link: str | None = None,
                  frames: Mapping[str, Mapping[str, Any]] | None = None,
                  contacts: Mapping[str, Mapping[str, Any]] | None = None) -> "SpatialRobot":
        """Loads a URDF; ``base`` attaches its root link to the world (``"free_flyer"``,
        ``"planar"``: in the world's ``x``-``z`` plane, or ``"fixed"``). Links with zero mass
        stay massless. ``frames`` adds frames to the URDF's, ``{name: {"parent": frame, "xyz_m": [x, y, z], "rpy_rad": [r, p, y]}}``
        (placed in the parent frame as a URDF joint origin places its child; offsets zero
        where not given; Pinocchio's operational frames): points to name as contacts, such
        as the corners of a flat foot. ``contacts`` declares the robot's contacts in the dict
        form, ``{frame: {"radius_m": r, "friction": mu, ...}}`` (checked here, each bad entry
        naming ``contacts[frame].key``): the methods that take contacts then take ``None``
        (all of them), a mode string of one ``0``/``1`` per declared contact in order
        (``"1011"``), or a list of declared names, each with its declared form."""
        if not isinstance(path, (str, os.PathLike)):
            raise InvalidTypeError(f"`path` must be a file path, got {type(path).__name__}", "path")
        robot = cls(_NativeSpatialRobot.from_urdf(os.fspath(path), base, root_link, frames))
        return robot._declare(contacts)

    def _declare(self, contacts: Mapping[str, Mapping[str, Any]] | None) -> "SpatialRobot":
        if contacts is None:
            return self
        if not isinstance(contacts, Mapping) or not all(isinstance(v, Mapping) for v in contacts.values()):
            raise InvalidTypeError("`contacts` must be a dict {frame: {\"radius_m\": ..., \"friction\": ...}}",
                                   "contacts")
        declared = {k: dict(v) for k, v in contacts.items()}
        self._native.free_rates(declared)  # parses every entry: a bad one names its field
        self._declared = declared
        return self

    @property
    def contacts(self) -> dict[str, dict[str, Any]]:
        """The contacts declared at ``from_urdf(contacts=...)``, in order (empty if none)."""
        return {k: dict(v) for k, v in self._declared.items()}

    def _contact_set(self, contacts: Contacts) -> list[str] | dict[str, Mapping[str, Any]]:
        """The contact set a method is given: frame names as a list, the dict form as a dict;
        with declared contacts, ``None`` (all), a mode string or a list of declared names."""
        declared = self._declared
        if isinstance(contacts, Mapping):
            return dict(contacts)
        if contacts is None or isinstance(contacts, str):
            if not declared:
                raise InvalidInputError("no contacts declared (from_urdf(contacts=...)): give the contacts, "
                                        "a list of frame names or a dict", "contacts")
            if contacts is None:
                return dict(declared)
            if len(contacts) != len(declared) or set(contacts) - {"0", "1"}:
                raise InvalidInputError(f"mode {contacts!r}: one 0/1 per declared contact ({len(declared)}: "
                                        f"{', '.join(declared)})", "contacts")
            return {k: v for (k, v), bit in zip(declared.items(), contacts) if bit == "1"}
        names = list(contacts)
        known = [n in declared for n in names]
        if declared and all(known):
            return {n: declared[n] for n in names}
        if any(known):
            others = ", ".join(str(n) for n, k in zip(names, known) if not k)
            raise InvalidInputError(f"a list mixing declared contacts with frames not declared ({others}): "
                                    "name declared contacts only, or give every contact as a dict", "contacts")
        return names

    @classmethod
    def rhex(cls, leg_mass_kg: float = 0.0, leg_inertia_kg_m2: float = 0.0,
             hip_half_width_m: float | None = None,
             base: Literal["free_flyer", "planar", "fixed"] = "free_flyer") -> "SpatialRobot":
        """RHex with six legs (thesis Table 4.2; massless legs by default, Assumption C.6):
        hips ``{front,middle,rear}_{left,right}_hip``, toe frames ``..._toe``. The hips'
        half-width (0.125 m by default) is an assumption, the thesis gives none. ``base`` as
        in :meth:`from_urdf` (``"planar"``: the body in the sagittal plane)."""
        return cls(_NativeSpatialRobot.rhex(float(leg_mass_kg), float(leg_inertia_kg_m2),
                                            None if hip_half_width_m is None else float(hip_half_width_m),
                                            base))

    @property
    def nv(self) -> int:
        return self._native.nv

    @property
    def joint_names(self) -> list[str]:
        return self._native.joint_names

    @property
    def frame_names(self) -> list[str]:
        return self._native.frame_names

    @property
    def gravity(self) -> np.ndarray:
        return np.array(self._native.gravity)

    @property
    def total_mass(self) -> float:
        return self._native.total_mass

    def neutral(self) -> np.ndarray:
        """Zero joints, base at the origin, identity orientation."""
        return self._native.neutral()

    def integrate(self, q: np.ndarray | Sequence[float], v: np.ndarray | Sequence[float]) -> np.ndarray:
        """``q ⊕ v`` on the configuration group."""
        return self._native.integrate(_vector(q), _vector(v))

    def difference(self, q0: np.ndarray | Sequence[float], q1: np.ndarray | Sequence[float]) -> np.ndarray:
        """``q1 ⊖ q0``: the ``v`` with ``integrate(q0, v) = q1``."""
        return self._native.difference(_vector(q0), _vector(q1))

    def from_pinocchio(self, q: np.ndarray | Sequence[float],
                       v: np.ndarray | Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """Pinocchio's ``(q, v)`` in this layout: a ``continuous`` joint's ``(cos θ, sin θ)``
        becomes its angle ``θ`` (Pinocchio's ``nq`` is one larger per continuous joint); every
        other coordinate and ``v`` are copied."""
        return self._native.q_from_pinocchio(_vector(q)), self._rates(v)

    def to_pinocchio(self, q: np.ndarray | Sequence[float],
                     v: np.ndarray | Sequence[float]) -> tuple[np.ndarray, np.ndarray]:
        """This layout's ``(q, v)`` in Pinocchio's: a ``continuous`` joint's angle ``θ``
        becomes ``(cos θ, sin θ)``; every other coordinate and ``v`` are copied."""
        return self._native.q_to_pinocchio(_vector(q)), self._rates(v)

    def _rates(self, v: np.ndarray | Sequence[float]) -> np.ndarray:
        """A copy of ``v``, checked (``nv`` finite entries, the typed error naming ``v``) by
        the native ``integrate`` at the neutral configuration."""
        v = _vector(v).copy()
        self._native.integrate(self._native.neutral(), v)
        return v

    def mass_matrix(self, q: np.ndarray | Sequence[float]) -> np.ndarray:
        """``M(q)``, nv x nv (singular when links are massless)."""
        return self._native.mass_matrix(_vector(q))

    def bias_forces(self, q: np.ndarray | Sequence[float], v: np.ndarray | Sequence[float]) -> np.ndarray:
        """``h(q, v) = C(q, v) v + g(q)`` (Pinocchio's ``nle``)."""
        return self._native.bias_forces(_vector(q), _vector(v))

    def frame_placement(self, q: np.ndarray | Sequence[float], name: str) -> np.ndarray:
        """The frame's placement in the world, a 4 x 4 homogeneous matrix."""
        return self._native.frame_placement(_vector(q), name)

    def frame_jacobian(self, q: np.ndarray | Sequence[float], name: str,
                       frame: ReferenceFrame = "local") -> np.ndarray:
        """The frame's 6 x nv Jacobian, linear rows first, in ``frame``."""
        return self._native.frame_jacobian(_vector(q), name, frame)

    def free_rates(self, contacts: Contacts) -> list[int]:
        """The rates of the massless limbs that ``contacts`` leave in the air (their subtree
        has no mass and no contact), ascending: ``dynamics`` needs their ``free_qdd``."""
        return self._native.free_rates(self._contact_set(contacts))

    def dynamics(self, contacts: Contacts, q: np.ndarray | Sequence[float],
                 v: np.ndarray | Sequence[float], tau: np.ndarray | Sequence[float],
                 free_qdd: np.ndarray | Sequence[float] | None = None) -> SpatialDynamics:
        """Forward dynamics with ``contacts`` held (see the module's conventions). A massless
        limb in the air (``free_rates``) follows the accelerations ``free_qdd`` (one per free
        rate); without them it is ``SingularKktError`` (Lemma 5.1)."""
        free = None if free_qdd is None else _vector(free_qdd)
        d = self._native.dynamics(self._contact_set(contacts), _vector(q), _vector(v), _vector(tau), free)
        return SpatialDynamics(d["qdd"], d["lam"], [tuple(r) for r in d["rows"]], d["A"], d["drift"])

    def kkt(self, contacts: Contacts, q: np.ndarray | Sequence[float]) -> SpatialKkt:
        """The blocks ``M_dagger``, ``A_dagger``, ``Lambda`` of the KKT inverse of ``contacts``
        at ``q`` (thesis 5.2; :class:`SpatialKkt`). Dependent rows raise ``SingularKktError``."""
        d = self._native.kkt(self._contact_set(contacts), _vector(q))
        d["rows"] = [tuple(r) for r in d["rows"]]
        return SpatialKkt(**d)

    def quasi_static(self, contacts: Contacts, q: np.ndarray | Sequence[float]) -> SpatialQuasiStatic:
        """Quasi-static forces of ``contacts`` at rest at ``q`` (thesis 4.21-4.22)."""
        d = self._native.quasi_static(self._contact_set(contacts), _vector(q))
        return SpatialQuasiStatic(d["grasp"], d["gravity_wrench"], d["lam_external"], d["internal_basis"],
                                  d["tau_external"], d["internal_torques"], [tuple(r) for r in d["rows"]])

    def impact(self, contacts: Contacts, q: np.ndarray | Sequence[float],
               v: np.ndarray | Sequence[float], lift_off: bool = False) -> SpatialImpact:
        """Plastic impact into ``contacts`` with incoming rates ``v``; a dict contact with
        ``friction`` meets Coulomb's cone. With ``lift_off`` each contact separates (state
        ``"separate"``: no impulse, its normal velocity after non-negative), sticks or slips
        by complementarity, frictionless contacts alike. Raises ``InvalidInputError`` naming
        ``contacts`` when no impact, or more than one, satisfies the contacts."""
        d = self._native.impact(self._contact_set(contacts), _vector(q), _vector(v), _flag(lift_off, "lift_off"))
        return _impact(d, d["rows"])

    def impact_outcomes(self, contacts: Contacts, q: np.ndarray | Sequence[float],
                        v: np.ndarray | Sequence[float], lift_off: bool = False) -> list[SpatialImpact]:
        """Every outcome of ``impact``'s complementarity problem, distinct in ``v_plus`` (none
        when no state of the contacts satisfies them, several in a Painlevé configuration,
        where ``impact`` raises)."""
        d = self._native.impact_outcomes(self._contact_set(contacts), _vector(q), _vector(v),
                                         _flag(lift_off, "lift_off"))
        return [_impact(o, d["rows"]) for o in d["outcomes"]]


def _flag(value: Any, field: str) -> bool:
    """``value`` as a bool, or ``InvalidTypeError`` naming ``field``."""
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidTypeError(f"`{field}` must be a bool, got {type(value).__name__}", field)
    return bool(value)


def _impact(d: Mapping[str, Any], rows: Sequence[Sequence[str]]) -> SpatialImpact:
    return SpatialImpact(d["v_plus"], d["impulse"], [tuple(r) for r in rows], list(d["states"]))
