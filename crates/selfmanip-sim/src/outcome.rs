//! What an execution amounts to, for tables and sweeps: how it ended, the contact-cell word,
//! the apex of its first flight, its first landing, its end state. Times are on the
//! execution clock; states in the world frame of `q` (NED: z down, φ nose-up).
use crate::labels::{contact_word, ContactLabels};
use selfmanip_core::Model;
use selfmanip_hybrid::{Event, EventKind, Execution, Termination};
use serde::Serialize;

/// How an execution ended ([`Termination`] without its payload).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RunStatus {
    FinalTime,
    Apex,
    Zeno,
    EventBudget,
    NoContactSolution,
    SeveralContactSolutions,
    TerrainDiscontinuity,
    Penetration,
    SingularFlow,
    StepBudget,
    StepTooSmall,
    Interrupted,
}

impl RunStatus {
    pub fn of(t: &Termination) -> Self {
        match t {
            Termination::FinalTime => RunStatus::FinalTime,
            Termination::Apex => RunStatus::Apex,
            Termination::Zeno { .. } | Termination::Chatter { .. } => RunStatus::Zeno,
            Termination::EventBudget => RunStatus::EventBudget,
            Termination::NoContactSolution { .. } => RunStatus::NoContactSolution,
            Termination::SeveralContactSolutions { .. } => RunStatus::SeveralContactSolutions,
            Termination::TerrainDiscontinuity { .. } => RunStatus::TerrainDiscontinuity,
            Termination::Penetration { .. } => RunStatus::Penetration,
            Termination::SingularFlow { .. } | Termination::Painleve { .. } => {
                RunStatus::SingularFlow
            }
            Termination::StepBudget { .. } => RunStatus::StepBudget,
            Termination::StepTooSmall { .. } => RunStatus::StepTooSmall,
            Termination::Interrupted { .. } => RunStatus::Interrupted,
        }
    }

    pub fn as_str(self) -> &'static str {
        match self {
            RunStatus::FinalTime => "final_time",
            RunStatus::Apex => "apex",
            RunStatus::Zeno => "zeno",
            RunStatus::EventBudget => "event_budget",
            RunStatus::NoContactSolution => "no_contact_solution",
            RunStatus::SeveralContactSolutions => "several_contact_solutions",
            RunStatus::TerrainDiscontinuity => "terrain_discontinuity",
            RunStatus::Penetration => "penetration",
            RunStatus::SingularFlow => "singular_flow",
            RunStatus::StepBudget => "step_budget",
            RunStatus::StepTooSmall => "step_too_small",
            RunStatus::Interrupted => "interrupted",
        }
    }

    /// Whether the run reached its final time or its apex (not stopped by the engine).
    pub fn is_complete(self) -> bool {
        matches!(self, RunStatus::FinalTime | RunStatus::Apex)
    }
}

/// The body's pose and velocity at one instant (world frame, NED: `z` down).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct BodyState {
    pub t_s: f64,
    pub x_m: f64,
    pub z_m: f64,
    pub phi_rad: f64,
    pub xdot_m_s: f64,
    pub zdot_m_s: f64,
    pub phidot_rad_s: f64,
}

impl BodyState {
    /// From a full state `[q; q̇]` of `model`.
    pub fn from_state(model: &Model, t: f64, q: &[f64], qd: &[f64]) -> Self {
        let (ix, iz, ip) = (model.ix_x(), model.ix_z(), model.ix_phi());
        BodyState {
            t_s: t,
            x_m: q[ix],
            z_m: q[iz],
            phi_rad: q[ip],
            xdot_m_s: qd[ix],
            zdot_m_s: qd[iz],
            phidot_rad_s: qd[ip],
        }
    }

    /// This state with `z` and `ż` up (height above the world's `z = 0`): the frame of every
    /// sweep's columns ([`APEX_COLUMNS`]).
    pub fn upward(self) -> Self {
        BodyState {
            z_m: -self.z_m,
            zdot_m_s: -self.zdot_m_s,
            ..self
        }
    }

    /// This state in a frame whose origin is the body at `x0_m` (forward), `z` up, on a clock
    /// starting at `t0_s`: a preset's frame from its start (chapter 3's apex).
    pub fn seen_from_start(self, t0_s: f64, x0_m: f64) -> Self {
        BodyState {
            t_s: self.t_s - t0_s,
            x_m: self.x_m - x0_m,
            z_m: -self.z_m,
            zdot_m_s: -self.zdot_m_s,
            ..self
        }
    }

    /// The state in the order of its fields: `[t, x, z, φ, ẋ, ż, φ̇]` (s, m, m, rad, m/s,
    /// m/s, rad/s).
    pub fn to_array(&self) -> [f64; 7] {
        [
            self.t_s,
            self.x_m,
            self.z_m,
            self.phi_rad,
            self.xdot_m_s,
            self.zdot_m_s,
            self.phidot_rad_s,
        ]
    }
}

/// The apex columns of every sweep, in the order of [`BodyState::to_array`]: the body at the
/// apex with `z` **up** — `apex_z_m` is the body centre's height above the world's `z = 0`
/// (the flat ground's level), `apex_zdot_m_s` its rate, positive up — on the preset's clock,
/// `apex_x_m` from the preset's forward origin ([`PresetFrame`]; a plain scenario's: the
/// world's). One meaning and sign in the leap sweep and in the sweep of any robot.
pub const APEX_COLUMNS: [&str; 7] = [
    "apex_t_s",
    "apex_x_m",
    "apex_z_m",
    "apex_phi_rad",
    "apex_xdot_m_s",
    "apex_zdot_m_s",
    "apex_phidot_rad_s",
];

/// What a preset reports of a run, and in which frame: its clock's origin `t0_s` on the
/// execution clock, the time its drive starts `drive_start_s` (a flight counts from then on),
/// its forward origin `x0_m`, and whether its runs stop at the first apex. A leap's: the
/// front motor's start, the first motor's, the body's start; a plain scenario's:
/// [`PresetFrame::world`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PresetFrame {
    pub t0_s: f64,
    pub drive_start_s: f64,
    pub x0_m: f64,
    pub stop_at_apex: bool,
}

impl PresetFrame {
    /// The execution's own clock and the world's `x` (flights counted from the start).
    pub fn world(stop_at_apex: bool) -> Self {
        PresetFrame {
            t0_s: 0.0,
            drive_start_s: 0.0,
            x0_m: 0.0,
            stop_at_apex,
        }
    }

    /// Whether the run flew: it reached the apex of a flight (stopping there), or, not
    /// stopping at the apex, flew after the drive started and ran on to its final time;
    /// `false` for every status the engine stopped the run with.
    pub fn flew(&self, exec: &Execution, status: RunStatus) -> bool {
        match status {
            RunStatus::Apex => true,
            RunStatus::FinalTime => flies_after(exec, self.drive_start_s) && !self.stop_at_apex,
            _ => false,
        }
    }

    /// The apex the run reports ([`reported_apex`]) in this frame, `z` up.
    pub fn apex(&self, model: &Model, exec: &Execution) -> Option<BodyState> {
        reported_apex(exec, self.stop_at_apex, self.drive_start_s).map(|e| {
            BodyState::from_state(model, e.t, &e.q, &e.qd_after)
                .seen_from_start(self.t0_s, self.x0_m)
        })
    }

    /// Why the run did not fly, in words, on this clock (empty when it `flew`): a run that
    /// reached its final time found no flight (or no apex) before `t_final_s` (on this
    /// clock); otherwise the engine's [`Termination::describe`] with the contacts' names
    /// (`name`) and the flowing mode's label (`mode`).
    pub fn reason(
        &self,
        exec: &Execution,
        flew: bool,
        t_final_s: f64,
        name: &dyn Fn(usize) -> String,
        mode: &str,
    ) -> String {
        if flew {
            return String::new();
        }
        if exec.termination == Termination::FinalTime {
            return format!(
                "no flight reached{} before t_final_s = {} s",
                if self.stop_at_apex { " its apex" } else { "" },
                t_final_s
            );
        }
        exec.termination
            .describe(&|t| format!("t = {:.6} s", t - self.t0_s), name, Some(mode))
    }
}

/// The first touchdown after the first flight.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Landing {
    /// The body just before the impact.
    pub before: BodyState,
    /// Contacts that touched down.
    pub contacts: Vec<String>,
    /// Mode label after the impact.
    pub mode_after: String,
    /// Kinetic energy lost in the impact (J).
    pub energy_loss_j: f64,
}

/// The metrics of one execution.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Outcome {
    pub status: RunStatus,
    /// Why the run ended short of its final time or apex, in words (empty if it did not):
    /// [`Termination::describe`] with the robot's contact names and the flowing mode's label.
    pub reason: String,
    pub t_end_s: f64,
    pub q_end: Vec<f64>,
    pub qd_end: Vec<f64>,
    pub mode_end: String,
    /// Contact cells visited (see [`contact_word`]).
    pub word: Vec<String>,
    pub n_events: usize,
    /// The highest point of the first flight that has one (where the body's upward speed
    /// `−ż` falls through zero): the engine's first apex event, terminal or recorded on the
    /// way (`selfmanip_hybrid::guard`).
    pub apex: Option<BodyState>,
    pub landing: Option<Landing>,
    /// Total time with no contact active (s).
    pub flight_time_s: f64,
    /// Kinetic energy lost in all impacts (J).
    pub impact_loss_j: f64,
}

impl Outcome {
    /// The word joined by `-`.
    pub fn word_string(&self) -> String {
        self.word.join("-")
    }
}

/// Whether a flight starts in `exec` at or after `after_s` (execution clock).
pub fn flies_after(exec: &Execution, after_s: f64) -> bool {
    exec.segments
        .iter()
        .any(|s| s.mode.is_flight() && s.t0 >= after_s)
}

/// The apex a run reports: the apex event that ended `exec`; a run that goes on past its
/// apexes (`stop_at_apex` false), its first apex at or after `after_s`.
pub fn reported_apex(exec: &Execution, stop_at_apex: bool, after_s: f64) -> Option<&Event> {
    match exec.termination {
        Termination::Apex => exec.events.last(),
        _ if !stop_at_apex => exec
            .events
            .iter()
            .find(|e| e.kind == EventKind::Apex && e.t >= after_s),
        _ => None,
    }
}

/// The time of contact `contact`'s first touchdown at or after `after_s` (execution clock).
pub fn first_touchdown_s(exec: &Execution, contact: usize, after_s: f64) -> Option<f64> {
    exec.events
        .iter()
        .find(|e| {
            e.kind == EventKind::Touchdown && e.t >= after_s && e.triggered.contains(&contact)
        })
        .map(|e| e.t)
}

/// How the word is formed.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct WordOptions {
    /// Cells held no longer than this are left out (s).
    pub min_duration_s: f64,
    /// Show a sliding contact as `1` (in contact) instead of `s`.
    pub sliding_as_contact: bool,
}

impl Default for WordOptions {
    fn default() -> Self {
        WordOptions {
            min_duration_s: 1e-7,
            sliding_as_contact: false,
        }
    }
}

/// The [`Outcome`] of `exec`, a run of `model`.
pub fn outcome(
    model: &Model,
    exec: &Execution,
    labels: &ContactLabels,
    word: WordOptions,
) -> Outcome {
    // the engine locates every apex of a flight as an event (terminal when stopping there)
    let apex = exec
        .events
        .iter()
        .find(|e| e.kind == EventKind::Apex)
        .map(|e| BodyState::from_state(model, e.t, &e.q, &e.qd_after));
    let first_flight = exec
        .segments
        .iter()
        .find(|s| s.mode.is_flight() && s.t1 > s.t0)
        .map(|s| s.t0);
    let landing = first_flight.and_then(|t_fly| {
        let e = exec
            .events
            .iter()
            .find(|e| e.kind == EventKind::Touchdown && e.t > t_fly)?;
        let seg = exec.segments.iter().rev().find(|s| s.t0 < e.t)?;
        let mut y = vec![0.0; 2 * model.nq()];
        seg.eval(e.t, &mut y);
        let (q, qd) = y.split_at(model.nq());
        Some(Landing {
            before: BodyState::from_state(model, e.t, q, qd),
            contacts: e
                .triggered
                .iter()
                .map(|&k| model.contacts[k].name.clone())
                .collect(),
            mode_after: labels.label(e.mode_after),
            energy_loss_j: e.kinetic_before - e.kinetic_after,
        })
    });
    let status = RunStatus::of(&exec.termination);
    let reason = if status.is_complete() {
        String::new()
    } else {
        exec.termination.describe(
            &|t| format!("t = {t:.6} s"),
            &|k| {
                model
                    .contacts
                    .get(k)
                    .map_or_else(|| format!("#{k}"), |c| c.name.clone())
            },
            Some(&labels.label(exec.mode)),
        )
    };
    Outcome {
        status,
        reason,
        t_end_s: exec.t,
        q_end: exec.q.clone(),
        qd_end: exec.qd.clone(),
        mode_end: labels.label(exec.mode),
        word: contact_word(exec, labels, word.min_duration_s, word.sliding_as_contact),
        n_events: exec.events.len(),
        apex,
        landing,
        flight_time_s: exec
            .segments
            .iter()
            .filter(|s| s.mode.is_flight())
            .map(|s| s.t1 - s.t0)
            .sum(),
        impact_loss_j: exec.impact_losses().iter().sum(),
    }
}
