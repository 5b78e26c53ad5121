//! `selfmanip`: one import for the whole engine.
//!
//! * [`core`] — frames, contacts, grasp map, KKT dynamics with massless limbs.
//! * [`hybrid`] — event-accurate hybrid executions: guards, impacts, complementarity.
//! * [`sim`] — any robot through the engine: scenarios, behaviours as data, terrains,
//!   trajectories, sweeps, MCAP logs, the analyses that take any model.
//! * [`rhex`] — the RHex instance, ground reaction complex, leap words.
//! * [`motor`] — motors, gearboxes, thermal model, tail gear ratio, leg observer.
pub use motor;
pub use rhex_model as rhex;
pub use selfmanip_core as core;
pub use selfmanip_hybrid as hybrid;
pub use selfmanip_sim as sim;
