"""Actuators (thesis chapter 2): motor/gearbox tables, thermal simulation, the tail gear-ratio
optimum of eq. (2.1), catalog ranking, and the leg observer with its fault machine.

All quantities are SI (rad/s, N m, kg, K or degC for temperatures). The built-in catalog holds
the motors and gearboxes of Tables 2.1-2.3 (drives ``research-rhex``, ``x-rhex-18``,
``x-rhex-28``); pass ``catalog_toml`` (same format as :func:`thesis_catalog_toml`) to use your
own.

>>> from selfmanip import motor
>>> opt = motor.tail_optimum(theta0_rad=1.5708, power_w=30.0, body_inertia_kg_m2=0.05,
...                          effectiveness=1.29)
>>> round(opt["completion_time_s"], 4)
0.2245
>>> [row["name"] for row in motor.drive_table()]
['research-rhex', 'x-rhex-18', 'x-rhex-28']
"""

from __future__ import annotations

from typing import Any

import numpy as np
import numpy.typing as npt

from . import _native
from ._checks import integer, real, text, vector
from .errors import InvalidTypeError

__all__ = [
    "calibrate_observer",
    "continuous_output_torque",
    "drive_table",
    "identify_faults",
    "observe",
    "operating_point",
    "rank_tail_motors",
    "tail_constants",
    "tail_optimum",
    "thermal_simulation",
    "thesis_catalog_toml",
    "torque_speed_curve",
]


#: The most samples :func:`thermal_simulation` runs (the engine's bound, 10**7).
MAX_PROFILE_SAMPLES: int = _native.MOTOR_MAX_PROFILE_SAMPLES


def _catalog(catalog_toml: Any) -> str | None:
    return None if catalog_toml is None else text("catalog_toml", catalog_toml)


def _limit(current_limit_a: Any) -> float | None:
    return None if current_limit_a is None else real("current_limit_a", current_limit_a)


def _drive(drive: Any, current_limit_a: Any, catalog_toml: Any) -> tuple[str, float | None, str | None]:
    """Which drive, as the native functions take it: its name, the controller's current
    limit in place of the catalog's (``None``: the catalog's) and the catalog."""
    return text("drive", drive), _limit(current_limit_a), _catalog(catalog_toml)


def _task(theta0_rad: Any, body_inertia_kg_m2: Any, effectiveness: Any) -> tuple[float, float, float]:
    """The tail's task as the native functions take it."""
    return (real("theta0_rad", theta0_rad), real("body_inertia_kg_m2", body_inertia_kg_m2),
            real("effectiveness", effectiveness))


def tail_optimum(theta0_rad: float, power_w: float, body_inertia_kg_m2: float,
                 effectiveness: float) -> dict[str, float]:
    """Eq. (2.1): the output no-load speed (a proxy for the gear ratio: motor no-load speed
    divided by it) that turns the body by ``theta0_rad`` fastest with a tail of effectiveness
    ``effectiveness`` driven at full voltage by a motor of peak power ``power_w``, and the
    completion time. Returns ``{"no_load_speed_rad_s", "completion_time_s"}``."""
    return dict(_native.motor_tail_optimum(_task(theta0_rad, body_inertia_kg_m2, effectiveness),
                                           real("power_w", power_w)))


def tail_constants() -> dict[str, float]:
    """The constants ``k_omega``, ``k_t`` of eq. (2.1) from the derivation (and ``s_star``,
    the optimal completion time in motor time constants)."""
    return dict(_native.motor_tail_constants())


def rank_tail_motors(theta0_rad: float, body_inertia_kg_m2: float, effectiveness: float, *,
                     max_length_m: float = 0.030, max_mass_kg: float = 0.200,
                     max_completion_time_s: float = 0.5, catalog_toml: str | None = None,
                     synthetic_count: int = 1546, seed: int = 7) -> dict[str, Any]:
    """Ranks catalog motors (default: a seeded synthetic catalog of 1,546) by analytic
    completion time under the section-2.1.1 constraints. Returns columns ``name, index,
    peak_power_w, gear_ratio, completion_time_s`` (fastest first) and ``invalid``: the
    ``(index, reason)`` of entries that could not be evaluated."""
    return dict(_native.motor_rank_tail_motors(
        _task(theta0_rad, body_inertia_kg_m2, effectiveness), real("max_length_m", max_length_m),
        real("max_mass_kg", max_mass_kg), real("max_completion_time_s", max_completion_time_s),
        _catalog(catalog_toml), integer("synthetic_count", synthetic_count, 0),
        integer("seed", seed, 0, 2**64 - 1)))


def thesis_catalog_toml() -> str:
    """The shipped catalog (Tables 2.1-2.3) as TOML text."""
    return _native.motor_thesis_catalog_toml()


def drive_table(catalog_toml: str | None = None, current_limit_a: float | None = None) -> list[dict[str, Any]]:
    """One row per motor/gearbox combination: Table 2.2's derived rows (output no-load speed,
    achievable output stall torque, continuous output torque, mass) plus peak output power and
    the Table 2.3 thermal data. ``current_limit_a`` overrides the controller limit (the thesis
    also evaluates 9 A)."""
    return [dict(r) for r in _native.motor_drive_table(
        _catalog(catalog_toml), _limit(current_limit_a))]


def torque_speed_curve(drive: str, points: int = 50, current_limit_a: float | None = None,
                       catalog_toml: str | None = None) -> dict[str, np.ndarray]:
    """Fig. 2.6: output torque and power against output speed at full command."""
    return dict(_native.motor_torque_speed_curve(_drive(drive, current_limit_a, catalog_toml),
                                                 integer("points", points, 0)))


def operating_point(drive: str, command: float, speed_rad_s: float, *, gearbox_loss: str = "derating",
                    battery_resistance_ohm: float = 0.0, current_limit_a: float | None = None,
                    catalog_toml: str | None = None) -> dict[str, float]:
    """One operating point of a drive at a voltage command ``command`` in [-1, 1] and output
    speed ``speed_rad_s``, with the drive's optional losses (``docs/calibration.md``, physics
    options): ``gearbox_loss="derating"`` (the default: output torque ``G η τ_m`` in both
    directions) or ``"power_flow"`` (``G η τ_m`` driving, ``G τ_m / η`` back-driven), and the
    battery's internal resistance (``V = V_oc − R_b I_b``; 0: an ideal source). Returns the
    output torque, the electrical power drawn from the battery's open-circuit voltage, the
    motor's torque and current, and the battery's current and terminal voltage."""
    return dict(_native.motor_operating_point(
        _drive(drive, current_limit_a, catalog_toml), real("command", command), real("speed_rad_s", speed_rad_s),
        text("gearbox_loss", gearbox_loss), real("battery_resistance_ohm", battery_resistance_ohm)))


def thermal_simulation(drive: str, torque_n_m: npt.ArrayLike, dt_s: float = 1.0, ambient_c: float = 25.0,
                       case: str = "measured", catalog_toml: str | None = None) -> dict[str, Any]:
    """Fig. 2.8: core and case temperature for an output-torque profile (one value per
    ``dt_s``; a scalar is not accepted -- pass ``np.full(n, torque)``). ``case`` selects
    Table 2.3's ``"measured"`` (with gearbox) or ``"listed"`` (bare motor) case parameters.
    Also returns the steady state for the profile's RMS torque."""
    profile = np.asarray(vector("torque_n_m", torque_n_m), dtype=np.float64)
    return dict(_native.motor_thermal_simulation(
        text("drive", drive), profile, real("dt_s", dt_s), real("ambient_c", ambient_c),
        text("case", case), _catalog(catalog_toml)))


def continuous_output_torque(drive: str, max_winding_c: float = 125.0, ambient_c: float = 25.0,
                             case: str = "measured", catalog_toml: str | None = None) -> float:
    """The output torque whose steady winding temperature is ``max_winding_c``."""
    return _native.motor_continuous_output_torque(
        text("drive", drive), real("max_winding_c", max_winding_c), real("ambient_c", ambient_c),
        text("case", case), _catalog(catalog_toml))


_OBSERVER_KEYS = ("k_m", "a_m", "k_p", "k_d", "k_g", "theta_g_rad", "delay_s")


def _observer_params(field: str, params: Any) -> dict[str, float]:
    if not isinstance(params, dict):
        raise InvalidTypeError(f"`{field}` must be a dict with keys {_OBSERVER_KEYS}, got {type(params).__name__}",
                               field)
    return {k: real(f"{field}.{k}", v) for k, v in params.items()}


def _log(dt_s: float, theta_d: npt.ArrayLike, omega_d: npt.ArrayLike, theta: npt.ArrayLike,
         omega: npt.ArrayLike) -> tuple:
    arrays = [np.asarray(vector(n, v), dtype=np.float64) for n, v in
              (("theta_d_rad", theta_d), ("omega_d_rad_s", omega_d), ("theta_rad", theta), ("omega_rad_s", omega))]
    return (real("dt_s", dt_s), *arrays)


def observe(params: dict, dt_s: float, theta_d_rad: npt.ArrayLike, omega_d_rad_s: npt.ArrayLike,
            theta_rad: npt.ArrayLike, omega_rad_s: npt.ArrayLike) -> dict[str, np.ndarray]:
    """Runs the leg observer (2.2)-(2.4) over a log and returns its delayed estimates and the
    residuals ``r_theta_rad``, ``r_omega_rad_s`` (2.5). ``params`` has keys ``k_m, a_m, k_p,
    k_d, k_g, theta_g_rad, delay_s``."""
    return dict(_native.motor_observe(_observer_params("params", params),
                                      *_log(dt_s, theta_d_rad, omega_d_rad_s, theta_rad, omega_rad_s)))


def calibrate_observer(initial_params: dict, dt_s: float, theta_d_rad: npt.ArrayLike,
                       omega_d_rad_s: npt.ArrayLike, theta_rad: npt.ArrayLike,
                       omega_rad_s: npt.ArrayLike) -> dict[str, Any]:
    """Nelder-Mead calibration of ``(k_m, a_m, k_g, theta_g_rad, k_d, delay_s)`` on a free-swing
    log (``k_p`` kept). Returns ``{"params", "rms_r_theta_rad", "rms_r_omega_rad_s",
    "evaluations"}``."""
    return dict(_native.motor_calibrate_observer(
        _observer_params("initial_params", initial_params),
        *_log(dt_s, theta_d_rad, omega_d_rad_s, theta_rad, omega_rad_s)))


def identify_faults(params: dict, config: dict, dt_s: float, theta_d_rad: npt.ArrayLike,
                    omega_d_rad_s: npt.ArrayLike, theta_rad: npt.ArrayLike,
                    omega_rad_s: npt.ArrayLike) -> list[dict[str, Any]]:
    """Observer plus the fault machine of Fig. 2.13 over a log; returns the state changes
    ``{"time_s", "from", "to"}``. ``config`` has ``phases`` (``landing_start_rad,
    ground_start_rad, takeoff_start_rad, air_start_rad``), ``low_residual_rad``,
    ``high_residual_rad``, ``min_dwell_s``, ``expect_ground``."""
    if not isinstance(config, dict):
        raise InvalidTypeError(f"`config` must be a dict, got {type(config).__name__}", "config")
    return list(_native.motor_identify_faults(
        config, _observer_params("params", params),
        *_log(dt_s, theta_d_rad, omega_d_rad_s, theta_rad, omega_rad_s)))
