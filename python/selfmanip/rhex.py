"""The RHex of thesis section 4.2, built through the generic robot description.

``Model()`` is the chapter-4 model: front and rear planar legs (each a contralateral pair) with
hips at ``+-l``, half-circle legs, massless legs (assumption C.6), Table 4.2 values. ``params``
overrides any Table 4.2 symbol::

    m_b, I_b      body mass [kg] and inertia [kg m^2]
    m_l, I_l      mass and inertia of one planar leg (a pair), COM at rho/2 on the hip-toe line
    l1, l2        body COM to front / rear hip [m]
    rho1, rho2    front / rear leg length [m]
    rho_b         radius of the body's rounded ends [m]
    tau_s         saturated torque of a planar leg [N m]
    g             gravity [m/s^2]
    leg_shape     "half_circle" or "stick"
    pairs         non-empty subset of ["front", "middle", "rear"]
    mu_front, mu_middle, mu_rear   toe friction (None: the toe never slips)

Coordinates ``q = [theta1, theta2, x, z, phi]`` (legs front to rear; z down; phi nose-up;
theta clockwise from the body's +z). Contact modes are chapter-3 labels, one character per
site in the order ``FB FL RB RL`` (``FB FL ML RB RL`` with three pairs): ``"0101"`` stands on
both legs, ``"1010"`` sits on the body, ``"0000"`` is flight; ``s`` marks a sliding toe. The
rows of ``lam`` follow chapter 4's order k = front leg, rear leg, front body, rear body
(tangential before normal; bodies slide, so they have a normal row only).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from . import _checks
from ._native import Robot as _NativeRobot
from ._native import ground_reaction_complex as _grc, rhex_default_params
from .errors import InvalidInputError, InvalidTypeError
from .robot import Robot

_REAL_KEYS = ("m_b", "I_b", "m_l", "I_l", "l1", "l2", "rho1", "rho2", "rho_b", "tau_s", "g")
_MU_KEYS = ("mu_front", "mu_middle", "mu_rear")


def default_params() -> dict[str, Any]:
    """Table 4.2 as shipped (``crates/rhex-model/data/table_4_2.toml``)."""
    return dict(rhex_default_params())


def ground_reaction_complex() -> dict[str, Any]:
    """The ground reaction complex of chapter 3 as data: ``cells`` (16, with contacts and
    DOF), ``hasse`` (64 directed single-contact transitions with their section-3.1.3
    category), ``allowable`` (the 18 of Fig. 3.3), ``leap_words`` ((3.2)-(3.7): printed form,
    full path from rest ``1010`` to flight ``0000``, and the timing condition) and the four
    leg ``strategies``. Labels are bits ``FB FL RB RL``."""
    return dict(_grc())


def _check_params(params: Mapping[str, Any]) -> dict[str, Any]:
    if not isinstance(params, Mapping):
        raise InvalidTypeError(f"`params` must be a dict, got {type(params).__name__}", "params")
    out: dict[str, Any] = {}
    for key, value in params.items():
        if not isinstance(key, str):
            raise InvalidTypeError(f"parameter names must be strings, got {key!r}", "params")
        if key in _REAL_KEYS or (key in _MU_KEYS and value is not None):
            out[key] = _checks.real(key, value)
            if not math.isfinite(out[key]):
                raise InvalidInputError(f"RHex parameter `{key}`: must be finite, got {value}", key)
        elif key in _MU_KEYS:
            out[key] = None
        elif key == "leg_shape":
            out[key] = _checks.text(key, value)
        elif key == "pairs":
            if isinstance(value, str) or not hasattr(value, "__iter__"):
                raise InvalidTypeError("`pairs` must be a list of strings", "pairs")
            out[key] = [_checks.text("pairs[]", p) for p in value]
        else:
            known = ", ".join(_REAL_KEYS + _MU_KEYS + ("leg_shape", "pairs"))
            raise InvalidInputError(f"unknown RHex parameter `{key}` (known: {known})", key)
    return out


@dataclass(frozen=True)
class ContactModeMap:
    """Fig. 4.3 / 4.6 as data on an ``n x n`` grid over ``theta1, theta2 in [-pi, pi)``:
    the quasi-static pitch ``phi`` (4.44; NaN where no pose balances), the supports of each side
    (``"B"`` body, ``"R"`` rolling leg, ``"T"`` toe) and the chapter-3 label of the contacts."""

    theta1: np.ndarray
    theta2: np.ndarray
    phi: np.ndarray
    height_m: np.ndarray
    front: np.ndarray
    rear: np.ndarray
    label: np.ndarray


class Model(Robot):
    """The RHex model (see the module docs for ``params``)."""

    def __init__(self, params: Mapping[str, Any] | None = None):
        checked = _check_params(params or {})
        super().__init__(_NativeRobot.rhex_from_params(checked))

    @property
    def params(self) -> dict[str, Any]:
        """The full parameter set in use."""
        return dict(self._native.params())

    def labels(self) -> list[str]:
        """Every 0/1 contact label (16 for two pairs)."""
        return list(self._native.labels())

    def description_toml(self) -> str:
        """The generic robot description this model is built from."""
        return self._native.description_toml()

    def quasi_static_pose(self, theta1: float, theta2: float) -> dict[str, Any] | None:
        """Pitch (4.44), supports and height with the legs at ``(theta1, theta2)``; ``None``
        where no pitch balances the two sides."""
        return self._native.quasi_static_pose(_checks.real("theta1", theta1), _checks.real("theta2", theta2))

    def contact_mode_map(self, n: int = 64) -> ContactModeMap:
        """Fig. 4.3/4.6 on an ``n x n`` grid (``1 <= n <= 1024``)."""
        n = _checks.integer("n", n)
        poses = self._native.contact_mode_map(n)
        grid = -np.pi + 2 * np.pi * np.arange(n) / n
        t1, t2 = np.meshgrid(grid, grid, indexing="ij")
        phi = np.full((n, n), np.nan)
        height = np.full((n, n), np.nan)
        front = np.full((n, n), "", dtype=object)
        rear = np.full((n, n), "", dtype=object)
        label = np.full((n, n), "", dtype=object)
        step = 2 * np.pi / n
        for p in poses:
            i = int(round((p["theta1"] + np.pi) / step))
            j = int(round((p["theta2"] + np.pi) / step))
            phi[i, j] = p["phi"]
            height[i, j] = p["height_m"]
            front[i, j], rear[i, j], label[i, j] = p["front"], p["rear"], p["label"]
        return ContactModeMap(t1, t2, phi, height, front, rear, label)
