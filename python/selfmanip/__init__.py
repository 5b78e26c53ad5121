"""selfmanip: hybrid dynamics of self-manipulating legged robots (the RHex thesis), a Rust
engine with thin Python bindings.

Conventions (once, for the whole package): SI units; world and body frames North-East-Down as
in the thesis (x forward, **z down**, pitch ``phi`` nose-up positive); generalized coordinates
``q = [joint angles..., x, z, phi]``; contact forces ``lam`` are the ground's force on the robot
in each contact frame (normal axis into the ground, so a pushing normal force is negative),
rows ordered by contact, tangential before normal.

Modules: :mod:`selfmanip.robot` (any planar robot from a description file),
:mod:`selfmanip.rhex` (the RHex of thesis section 4.2),
:mod:`selfmanip.motor` (motors, gearboxes, thermal model, tail optimum, leg observer), :mod:`selfmanip.cli` (the
``selfmanip`` command).
"""

from __future__ import annotations

from ._native import SelfmanipError, SingularKktError
from .robot import Dynamics, Impact, KktBlocks, QuasiStatic, Robot
from . import motor, rhex
from . import analysis
from . import distributed, plots
from .leap import LeapResult, leap, sweep

__all__ = [
    "Dynamics",
    "Impact",
    "KktBlocks",
    "QuasiStatic",
    "Robot",
    "SelfmanipError",
    "SingularKktError",
    "analysis",
    "distributed",
    "leap",
    "LeapResult",
    "plots",
    "sweep",
    "motor",
    "rhex",
]
__version__ = "0.1.0"
