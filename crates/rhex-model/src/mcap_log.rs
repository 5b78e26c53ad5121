//! RHex leap logs as MCAP files: a leap's trajectory and events through the generic writer
//! of [`selfmanip_sim::mcap`] (its topics and schemas), with the leg frames named after the
//! pairs (`<pair>_hip`); a leap's `q` names are the generic ones
//! ([`selfmanip_sim::trajectory::q_names`]: `<pair>_theta`, `x`, `z`, `phi`).
use crate::params::RhexParams;
use crate::{Rhex, RhexError};
use selfmanip_sim::events::EventRecord;
use selfmanip_sim::mcap::{write_mcap, write_mcap_to, Layout, McapLog};
use selfmanip_sim::Trajectory;
use std::collections::BTreeMap;
use std::io::{Seek, Write};
use std::path::Path;

pub use selfmanip_sim::mcap::FORCE_ARROW_M_PER_N;

/// What a log holds.
pub struct LeapLog<'a> {
    pub trajectory: &'a Trajectory,
    pub events: &'a [EventRecord],
    pub params: &'a RhexParams,
    /// Written as the `selfmanip` metadata record.
    pub metadata: BTreeMap<String, String>,
}

/// The generic log of a leap log: the robot of `params`, its frames, its samples.
fn generic<R>(
    log: &LeapLog<'_>,
    write: impl FnOnce(&McapLog<'_>) -> Result<R, selfmanip_sim::SimError>,
) -> Result<R, RhexError> {
    let rhex = Rhex::new(log.params.clone())?;
    let model = &rhex.model;
    let mut layout = Layout::of(model);
    layout.link_frames = model
        .joints
        .iter()
        .map(|j| format!("{}_hip", model.legs[j.leg].name))
        .collect();
    Ok(write(&McapLog {
        model,
        trajectory: log.trajectory,
        events: log.events,
        metadata: log.metadata.clone(),
        layout,
    })?)
}

/// Writes the MCAP stream of a leap to any seekable writer.
pub fn write_leap_mcap_to<W: Write + Seek>(w: W, log: &LeapLog<'_>) -> Result<W, RhexError> {
    generic(log, |g| write_mcap_to(w, g))
}

/// Writes the log to `path` atomically (temporary file in the same directory, fsync,
/// rename).
pub fn write_leap_mcap(path: &Path, log: &LeapLog<'_>) -> Result<(), RhexError> {
    generic(log, |g| write_mcap(path, g))
}
