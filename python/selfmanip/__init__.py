"""selfmanip: hybrid dynamics of self-manipulating legged robots (the RHex thesis), a Rust
engine with thin Python bindings.

Conventions (once, for the whole package): SI units; world and body frames North-East-Down as
in the thesis (x forward, **z down**, pitch ``phi`` nose-up positive); generalized coordinates
``q = [joint angles..., x, z, phi]``; contact forces ``lam`` are the ground's force on the robot
in each contact frame (normal axis into the ground, so a pushing normal force is negative),
rows ordered by contact, tangential before normal.

Modules: :mod:`selfmanip.robot` (any planar robot from a description file: dynamics,
kinematics, Jacobians, contacts), :mod:`selfmanip.rhex` (the RHex of thesis section 4.2),
:mod:`selfmanip.leap` (RHex leaps and sweeps; the module is also callable as
:func:`selfmanip.leap.leap`), :mod:`selfmanip.actuator` (the leap's :class:`Saturated` torque
or :class:`GearedMotor`), :mod:`selfmanip.simulation` (any robot, any behaviour:
:func:`simulate`, and :func:`sweep` for any robot or, given a strategy, the RHex leap sweep),
:mod:`selfmanip.analysis` (section 4.3), :mod:`selfmanip.calibrate` (fit a leap's parameters
to measured runs),
:mod:`selfmanip.motor` (motors, gearboxes, thermal model, tail optimum, leg observer),
:mod:`selfmanip.plots`, :mod:`selfmanip.distributed`, :mod:`selfmanip.errors` (the exception
hierarchy under :class:`SelfmanipError`) and :mod:`selfmanip.cli` (the ``selfmanip`` command).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import (AllPointsFailedWarning, ControllerError, EngineError, IllPosedError, InvalidInputError,
                     InvalidTypeError, SelfmanipError, SingularKktError)
from .robot import ContactPoints, Dynamics, Impact, Kinematics, KktBlocks, PointJacobian, QuasiStatic, Robot
from . import actuator, errors, motor, rhex
from .actuator import GearedMotor, Saturated
from . import analysis
from . import distributed, plots
from .leap import DEFAULT, LeapResult
from . import simulation
from .calibrate import Calibration, calibrate
from .spatial import SpatialRobot
from .simulation import EnergyReport, Execution, PeriodicOrbit, SimTrajectory, periodic_orbit, simulate, sweep

if TYPE_CHECKING:
    from .leap import leap as leap
else:
    # the module itself, callable: ``selfmanip.leap(...)`` runs a leap, ``import selfmanip.leap``
    # and ``from selfmanip.leap import sweep_points`` reach the module
    from . import leap

__all__ = [
    "AllPointsFailedWarning",
    "Calibration",
    "ContactPoints",
    "ControllerError",
    "DEFAULT",
    "Dynamics",
    "EnergyReport",
    "EngineError",
    "Execution",
    "GearedMotor",
    "IllPosedError",
    "Impact",
    "InvalidInputError",
    "InvalidTypeError",
    "Kinematics",
    "KktBlocks",
    "LeapResult",
    "PeriodicOrbit",
    "PointJacobian",
    "QuasiStatic",
    "Robot",
    "Saturated",
    "SelfmanipError",
    "SimTrajectory",
    "SingularKktError",
    "SpatialRobot",
    "actuator",
    "analysis",
    "calibrate",
    "distributed",
    "errors",
    "leap",
    "motor",
    "periodic_orbit",
    "plots",
    "rhex",
    "simulate",
    "simulation",
    "sweep",
]
__version__ = "0.1.0"
