//! `selfmanip`: one import for the whole engine.
//!
//! * [`core`] — frames, contacts, grasp map, KKT dynamics with massless limbs.
//! * [`hybrid`] — event-accurate hybrid executions: guards, impacts, complementarity.
//! * [`rhex`] — the RHex instance, ground reaction complex, leap words.
//! * [`motor`] — motors, gearboxes, thermal model, tail gear ratio, leg observer.
pub use motor;
pub use rhex_model as rhex;
pub use selfmanip_core as core;
pub use selfmanip_hybrid as hybrid;
