//! # motor
//!
//! The actuator side of the RHex thesis (chapter 2), in SI units with units in names:
//!
//! - [`dc`]: the linear DC motor at any supply voltage with a controller current limit, the
//!   gearbox, their combination (Table 2.2's derived rows, Fig. 2.6's curves), and the
//!   [`Actuator`] trait the leap simulation drives, and the drive's optional losses
//!   ([`DriveLosses`]: the gearbox loss by power flow, the battery's internal resistance);
//! - [`catalog`]: Tables 2.1–2.3 as a TOML catalog, user catalogs, a synthetic catalog;
//! - [`thermal`]: the two-node thermal model of Fig. 2.7, heat coefficients, winding-limited
//!   continuous torque, the case-parameter fit of Fig. 2.9;
//! - [`tail`]: the minimum-time tail gear ratio of eq. (2.1), derived, with a numerical
//!   cross-check and catalog ranking;
//! - [`observer`]: the leg observer (2.2)–(2.5), the fault-identification machine of
//!   Fig. 2.13, the Buehler clock, and the Nelder–Mead calibration;
//! - [`nelder_mead`]: the simplex minimizer both fits use; [`numeric`]: an RK4 step and
//!   bisection.
pub mod catalog;
pub mod dc;
pub mod error;
pub mod geared;
pub mod nelder_mead;
pub mod numeric;
pub mod observer;
pub mod tail;
pub mod thermal;

pub use catalog::{CaseParameters, Catalog, MotorSpec};
pub use dc::{Actuator, DcMotor, Drive, DriveLosses, Gearbox, GearboxLoss, SaturatedTorque};
pub use error::{MotorError, Result};
pub use thermal::{HeatInput, ThermalModel, ThermalState};
