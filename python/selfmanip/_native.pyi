"""Type stubs for the native module ``selfmanip._native`` (pyo3; ``crates/pybind``).

Everything here is private: use the documented wrappers in ``selfmanip.*``. Structured values
cross as plain Python objects (``dict``/``list``/``float``/``str``) and numpy arrays. Errors are
the classes of :mod:`selfmanip.errors` (mapped from the Rust error variants); long calls release
the GIL and raise ``KeyboardInterrupt`` on Ctrl-C.
"""

from os import PathLike
from typing import Any, Callable, Literal, TypedDict, final

import numpy as np
import numpy.typing as npt

_F64 = npt.NDArray[np.float64]
_I64 = npt.NDArray[np.int64]

# --------------------------------------------------------------------------------------- robot

class _Dynamics(TypedDict):
    qdd: _F64
    lam: _F64
    rows: list[tuple[str, str]]
    free_joints: list[int]
    mode: str

class _Kkt(TypedDict):
    m_dagger: _F64
    a_dagger: _F64
    Lambda: _F64
    A: _F64
    M: _F64
    rows: list[tuple[str, str]]
    dynamic_coords: list[int]
    constraint_condition: float
    reduced_mass_condition: float

class _Impact(TypedDict):
    qd_plus: _F64
    impulse: _F64
    rows: list[tuple[str, str]]

class _QuasiStatic(TypedDict):
    G_s: _F64
    J_h: _F64
    internal_basis: _F64
    internal_torques: _F64
    f_particular: _F64
    lam_particular: _F64
    tau_particular: _F64
    gravity_wrench: list[float]

class _Pose(TypedDict):
    theta1: float
    theta2: float
    phi: float
    front: str
    rear: str
    height_m: float
    label: str

class _Kinematics(TypedDict, total=False):
    body_position_m: _F64
    body_angle_rad: float
    joint_positions_m: _F64
    link_angles_rad: _F64
    link_tips_m: _F64
    body_velocity_m_s: _F64
    body_rate_rad_s: float
    joint_velocities_m_s: _F64
    link_rates_rad_s: _F64
    link_tip_velocities_m_s: _F64

class _PointJacobian(TypedDict):
    position_m: _F64
    angle_rad: float
    jacobian: _F64

class _ContactPoints(TypedDict, total=False):
    names: list[str]
    points_m: _F64
    gaps_m: _F64
    normals: _F64
    jacobians: _F64
    velocities_m_s: _F64

@final
class Robot:
    @staticmethod
    def rhex_from_params(params: dict[str, Any]) -> Robot: ...
    @staticmethod
    def from_description(text: str, format: Literal["toml", "json"]) -> Robot: ...
    @staticmethod
    def from_description_data(description: dict[str, Any]) -> Robot: ...
    def description_data(self) -> dict[str, Any]: ...
    def __reduce__(self) -> tuple[Callable[..., Any], tuple[Any, ...]]: ...
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int: ...
    @property
    def n_joints(self) -> int: ...
    @property
    def contact_names(self) -> list[str]: ...
    @property
    def coordinate_names(self) -> list[str]: ...
    @property
    def is_rhex(self) -> bool: ...
    def params(self) -> dict[str, Any]: ...
    def description_toml(self) -> str: ...
    def labels(self) -> list[str] | None: ...
    def mode_spec(self, mode: str) -> str: ...
    def dynamics(
        self,
        mode: str,
        q: list[float],
        qd: list[float],
        tau: list[float],
        free_joint_qdd: list[float] | None = None,
    ) -> _Dynamics: ...
    def kkt(self, mode: str, q: list[float]) -> _Kkt: ...
    def impact(self, mode: str, q: list[float], qd_minus: list[float]) -> _Impact: ...
    def energy(self, q: list[float], qd: list[float]) -> tuple[float, float]: ...
    def contact_gaps(self, q: list[float]) -> list[tuple[str, float]]: ...
    def forward_kinematics(self, q: list[float], qd: list[float] | None = None) -> _Kinematics: ...
    def jacobian(
        self, q: list[float], part: int | None = None, point_m: tuple[float, float] | list[float] = ...
    ) -> _PointJacobian: ...
    def contact_points(self, q: list[float], qd: list[float] | None = None) -> _ContactPoints: ...
    def quasi_static(
        self, mode: str, q: list[float], torque_constraints: list[list[float]] = ...
    ) -> _QuasiStatic: ...
    def quasi_static_pose(self, theta1: float, theta2: float) -> _Pose | None: ...
    def contact_mode_map(self, n: int) -> list[_Pose]: ...

def rhex_default_params() -> dict[str, Any]: ...
def ground_reaction_complex() -> dict[str, Any]: ...

# ---------------------------------------------------------------------------------------- leap

# the fields of ``selfmanip.leap.Apex``, which the wrapper builds from it (declared there once)
_Apex = dict[str, float]

class _Event(TypedDict):
    t_s: float
    kind: str
    mode_before: str
    mode_after: str
    contacts: list[str]
    energy_loss_j: float

class _LeapTrajectory(TypedDict):
    contacts: list[str]
    t_s: _F64
    q: _F64
    qd: _F64
    mode: list[str]
    contact_points_m: _F64
    contact_forces_n: _F64

class _Leap(TypedDict, total=False):
    status: str
    flew: bool
    reason: str
    apex: _Apex | None
    word: list[str]
    events: list[_Event]
    q0: _F64
    q_names: list[str]
    time_offset_s: float
    params: dict[str, Any]
    config: dict[str, Any]
    trajectory: _LeapTrajectory

class _SweepColumns(TypedDict):
    gear_ratio: _F64
    apex_t_s: _F64
    apex_x_m: _F64
    apex_z_m: _F64
    apex_phi_rad: _F64
    apex_xdot_m_s: _F64
    apex_zdot_m_s: _F64
    apex_phidot_rad_s: _F64
    n_events: _I64
    word: list[str]
    status: list[str]
    flew: npt.NDArray[np.bool_]
    error: list[str]

class _Defaults(TypedDict):
    params: dict[str, Any]
    config: dict[str, Any]

def leap_sweepable_names() -> list[str]: ...
def leap_actuator_fields() -> list[str]: ...
def leap_defaults() -> _Defaults: ...
def leap_grammar_text() -> str: ...
def leap_word_equation(cells: list[str]) -> str | None: ...
def leap_run(
    strategy: str,
    t2_s: float,
    gear_ratio: float | None,
    overrides: dict[str, Any],
    dt_s: float | None = None,
) -> _Leap:
    """``gear_ratio``: ``None`` the engine's default actuator, a number the geared motor of
    that ratio, NaN the saturated torque."""

def leap_sweep(
    strategies: list[str],
    t2_s: list[float],
    gear_ratio: list[float | None],
    base_overrides: dict[str, Any],
    columns: dict[str, list[Any]],
    threads: int,
    progress: Callable[[int], object] | None = None,
) -> _SweepColumns: ...
def leap_write_mcap(
    path: str | PathLike[str],
    params: dict[str, Any],
    contacts: list[str],
    t_s: list[float],
    q: _F64,
    qd: _F64,
    mode: list[str],
    contact_points_m: _F64,
    contact_forces_n: _F64,
    events: list[dict[str, Any]],
    metadata: dict[str, str],
) -> None: ...

# ------------------------------------------------------------------------------------ analysis

_Params = dict[str, Any] | None

def analysis_sensor_pitch_range(params: _Params, grid: int) -> dict[str, Any]: ...
def analysis_holding_torque(params: _Params, theta1: float, theta2: float) -> dict[str, Any]: ...
def analysis_pitch_rate_gain(params: _Params, theta1: float, theta2: float) -> float: ...
def analysis_fig_4_8(
    params: _Params, theta1_range: list[float], theta2_range: list[float], n: int
) -> list[dict[str, Any]]: ...
def analysis_fig_4_10(
    params: _Params, theta2_range: list[float], phi_range: list[float], n: int, gear_ratio: float
) -> list[dict[str, Any]]: ...
def analysis_fig_4_11(
    params: _Params, ratios: list[float], phis: list[float], theta2_range: list[float]
) -> list[dict[str, Any]]: ...
def analysis_fig_4_12(
    params: _Params, phi_dots: list[float], phis: list[float], theta2_range: list[float], gear_ratio: float
) -> list[dict[str, Any]]: ...
def analysis_takeoff_speed(
    params: _Params, leg_kind: str, theta2: float, phi: float, phi_dot: float, gear_ratio: float
) -> dict[str, Any] | None: ...
def analysis_optimal_gear_ratio(
    params: _Params, phi: float, phi_dot: float, theta2_range: list[float], ratio_range: list[float]
) -> tuple[float, float]: ...
def analysis_splay_derivative(params: _Params, theta_m: float, theta_m_dot: float, tau: float) -> float: ...
def analysis_single_leg_pitch_accel(
    params: _Params, leg_kind: str, theta2: float, phi: float, theta2_dot: float, phi_dot: float, tau2: float
) -> float: ...
def analysis_leg_effectiveness(params: _Params, pairs: int) -> float: ...
def analysis_tail_effect(
    robot: Robot, q0: list[float], joints: list[int], period_s: float, dt_s: float
) -> dict[str, Any]: ...
def analysis_standing_rhex(
    params: _Params, leg_shape: str, seed: int, max_slope_rad: float, tau_d0: float, dt_s: float, steps: int
) -> dict[str, Any]: ...

# --------------------------------------------------------------------------------------- motor

# a tail's task: theta0_rad, body_inertia_kg_m2, effectiveness
_TailTask = tuple[float, float, float]

def motor_tail_optimum(task: _TailTask, power_w: float) -> dict[str, float]: ...
def motor_tail_constants() -> dict[str, float]: ...
def motor_rank_tail_motors(
    task: _TailTask,
    max_length_m: float,
    max_mass_kg: float,
    max_completion_time_s: float,
    catalog_toml: str | None = None,
    synthetic_count: int = 1546,
    seed: int = 7,
) -> dict[str, Any]: ...
def motor_thesis_catalog_toml() -> str: ...
def motor_drive_table(catalog_toml: str | None = None, current_limit_a: float | None = None) -> list[dict[str, Any]]: ...
# a drive: its name, a current limit in place of the catalog's, the catalog (TOML text)
_DriveChoice = tuple[str, float | None, str | None]

def motor_torque_speed_curve(drive: _DriveChoice, points: int = 50) -> dict[str, _F64]: ...
def motor_operating_point(
    drive: _DriveChoice, command: float, speed_rad_s: float, gearbox_loss: str = "derating",
    battery_resistance_ohm: float = 0.0
) -> dict[str, float]: ...
def motor_thermal_simulation(
    drive: str,
    torque_n_m: _F64,
    dt_s: float,
    ambient_c: float = 25.0,
    case: str = "measured",
    catalog_toml: str | None = None,
) -> dict[str, Any]: ...
def motor_continuous_output_torque(
    drive: str,
    max_winding_c: float = 125.0,
    ambient_c: float = 25.0,
    case: str = "measured",
    catalog_toml: str | None = None,
) -> float: ...
def motor_observe(
    params: dict[str, float], dt_s: float, theta_d: _F64, omega_d: _F64, theta: _F64, omega: _F64
) -> dict[str, _F64]: ...
def motor_calibrate_observer(
    initial_params: dict[str, float], dt_s: float, theta_d: _F64, omega_d: _F64, theta: _F64, omega: _F64
) -> dict[str, Any]: ...
MOTOR_MAX_PROFILE_SAMPLES: int
SIM_MAX_SWEEP_POINTS: int

def motor_identify_faults(
    config: dict[str, Any],
    params: dict[str, float],
    dt_s: float,
    theta_d: _F64,
    omega_d: _F64,
    theta: _F64,
    omega: _F64,
) -> list[dict[str, Any]]: ...

# ------------------------------------------------------------------------ simulation (any robot)

# an event of any robot: the fields of a leap's event and the contact impulse
class _SimEvent(_Event):
    impulse: list[float]

class _SimSegment(TypedDict):
    t0_s: float
    t1_s: float
    mode: str

class _SimTrajectory(TypedDict):
    q_names: list[str]
    contacts: list[str]
    t_s: _F64
    q: _F64
    qd: _F64
    tau: _F64
    mode: list[str]
    contact_points_m: _F64
    contact_forces_n: _F64

# the fields of ``selfmanip.simulation.EnergyReport``, which the wrapper builds from it
_SimEnergy = dict[str, float]

class _SimDefaults(TypedDict):
    t_final_s: float
    sample_dt_s: float
    options: dict[str, Any]

def sim_defaults() -> _SimDefaults: ...

@final
class Scenario:
    def __init__(
        self,
        robot: Robot | str | PathLike[str] | dict[str, Any],
        behaviour: str | PathLike[str] | dict[str, Any] | None,
        q0: list[float],
        qd0: list[float] | None = None,
        terrain: str | dict[str, Any] | None = None,
        contacts: list[str] | None = None,
        solve: list[str] | None = None,
        options: dict[str, Any] | None = None,
    ) -> None: ...
    @staticmethod
    def from_file(path: str | PathLike[str]) -> Scenario: ...
    @staticmethod
    def from_dict(data: dict[str, Any]) -> Scenario: ...
    def __reduce__(self) -> tuple[Callable[..., Any], tuple[Any, ...]]: ...
    def set(self, name: str, value: Any) -> None: ...
    def settable_names(self) -> list[str]: ...
    def to_dict(self) -> dict[str, Any]: ...
    def q_names(self) -> list[str]: ...
    def run(self, controller: Callable[[float, _F64, _F64, str], Any] | None = None) -> Run: ...
    def sweep(
        self,
        over: list[tuple[str, list[Any]]],
        threads: int,
        progress: Callable[[int], object] | None = None,
    ) -> dict[str, Any]: ...
    def periodic_orbit(self, options: dict[str, Any] | None = None) -> dict[str, Any]: ...

@final
class Run:
    def __reduce__(self) -> tuple[Callable[..., Any], tuple[Any, ...]]: ...
    @property
    def status(self) -> str: ...
    @property
    def reason(self) -> str: ...
    @property
    def word(self) -> list[str]: ...
    @property
    def q_names(self) -> list[str]: ...
    @property
    def labels(self) -> list[str]: ...
    def outcome(self) -> dict[str, Any]: ...
    def events(self) -> list[_SimEvent]: ...
    def segments(self) -> list[_SimSegment]: ...
    def trajectory(self, dt_s: float | None = None) -> _SimTrajectory: ...
    def energy_report(self) -> _SimEnergy: ...
    def sensitivity(self) -> dict[str, Any]: ...
    def write_mcap(
        self, path: str | PathLike[str], dt_s: float | None = None, metadata: dict[str, str] | None = None
    ) -> None: ...

@final
class SpatialRobot:
    @staticmethod
    def from_urdf(path: str, base: str = "free_flyer", root_link: str | None = None,
                  frames: dict[str, dict[str, Any]] | None = None) -> SpatialRobot: ...
    @staticmethod
    def from_urdf_text(urdf: str, base: str = "free_flyer", root_link: str | None = None,
                       frames: dict[str, dict[str, Any]] | None = None) -> SpatialRobot: ...
    @staticmethod
    def rhex(
        leg_mass_kg: float = 0.0,
        leg_inertia_kg_m2: float = 0.0,
        hip_half_width_m: float | None = None,
        base: str = "free_flyer",
    ) -> SpatialRobot: ...
    def __reduce__(self) -> tuple[Callable[..., Any], tuple[Any, ...]]: ...
    @property
    def name(self) -> str: ...
    @property
    def nq(self) -> int: ...
    @property
    def nv(self) -> int: ...
    @property
    def joint_names(self) -> list[str]: ...
    @property
    def frame_names(self) -> list[str]: ...
    @property
    def gravity(self) -> list[float]: ...
    @property
    def total_mass(self) -> float: ...
    def neutral(self) -> _F64: ...
    def integrate(self, q: _F64, v: _F64) -> _F64: ...
    def difference(self, q0: _F64, q1: _F64) -> _F64: ...
    def mass_matrix(self, q: _F64) -> _F64: ...
    def bias_forces(self, q: _F64, v: _F64) -> _F64: ...
    def frame_placement(self, q: _F64, name: str) -> _F64: ...
    def frame_jacobian(self, q: _F64, name: str, frame: str = "local") -> _F64: ...
    def dynamics(self, contacts: list[str] | dict[str, Any], q: _F64, v: _F64, tau: _F64,
                 free_qdd: _F64 | None = None) -> dict[str, Any]: ...
    def free_rates(self, contacts: list[str] | dict[str, Any]) -> list[int]: ...
    def impact(self, contacts: list[str] | dict[str, Any], q: _F64, v: _F64, lift_off: bool = False) -> dict[str, Any]: ...
    def impact_outcomes(self, contacts: list[str] | dict[str, Any], q: _F64, v: _F64, lift_off: bool = False) -> dict[str, Any]: ...
    def quasi_static(self, contacts: list[str] | dict[str, Any], q: _F64) -> dict[str, Any]: ...
    def kkt(self, contacts: list[str] | dict[str, Any], q: _F64) -> dict[str, Any]: ...
