//! How far off its surface an active contact may be: within [`TERRAIN_STEP_M`] it is on it;
//! up to [`MAX_DRIFT_M`] on the same feature it has drifted ([`crate::drift`]); further it
//! left it ([`crate::features`]).

/// A contact found this far from its surface left it other than continuously: its ground
/// stepped (m).
pub const TERRAIN_STEP_M: f64 = 1e-6;

/// The largest drift of a contact off its surface that is corrected (m); further, it left the
/// surface (a terrain step smaller than this is not told apart from drift).
pub const MAX_DRIFT_M: f64 = 1e-3;
