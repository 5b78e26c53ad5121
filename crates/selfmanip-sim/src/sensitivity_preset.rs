//! What a preset reports of a run's sensitivities to its named parameters
//! ([`crate::sensitivity`]): the derivatives of the body state at the event that ends the
//! run (a leap's apex), in the preset's frame (z up or down) and on its clock, whose origin
//! a parameter may move (a leap's `t2 < 0` moves its front motor's start); every event's
//! saltation and time gradient; and, where a derivative is not defined, why (all of them
//! NaN then).
use crate::sensitivity::{
    end_event_time_gradient, event_saltations, named_sensitivity_columns, time_event_jumps,
    undefined_reason, EventSaltation,
};
use nalgebra::DMatrix;
use selfmanip_core::{Model, Terrain};
use selfmanip_hybrid::sensitivity::Parameter;
use selfmanip_hybrid::{EventKind, Execution};

/// The body-state entries of the end state, in the order of the rows of
/// [`EndStateSensitivity::d_state`] (those of [`crate::outcome::BodyState`]).
pub const BODY_STATE_ENTRIES: [&str; 7] = [
    "t_s",
    "x_m",
    "z_m",
    "phi_rad",
    "xdot_m_s",
    "zdot_m_s",
    "phidot_rad_s",
];

/// The start-state directions of a request (`2nq × d` for `model`; none when not given);
/// an error names `directions` when their rows are not `2nq`.
pub fn start_directions(
    model: &Model,
    directions: Option<&DMatrix<f64>>,
) -> Result<DMatrix<f64>, crate::SimError> {
    let n2 = 2 * model.nq();
    let dirs = directions.cloned().unwrap_or_else(|| DMatrix::zeros(n2, 0));
    if dirs.nrows() != n2 {
        let reason = format!("expected {n2} rows, got {}", dirs.nrows());
        return Err(crate::error::invalid("directions", reason));
    }
    Ok(dirs)
}

/// A request for [`end_state_sensitivity`]: the run, what to differentiate along, and how the
/// preset reads it.
pub struct EndStateRequest<'a> {
    pub model: &'a Model,
    pub terrain: &'a dyn Terrain,
    pub exec: &'a Execution,
    /// Start-state directions (`2nq × nd`).
    pub directions: &'a DMatrix<f64>,
    /// Per named parameter, the engine parameters whose weighted sum it is.
    pub named: &'a [Vec<(Parameter, f64)>],
    /// The parameters' names (for the reason a derivative is not finite).
    pub names: &'a [&'a str],
    /// The caller's clock: execution time minus `offset_s`.
    pub offset_s: f64,
    /// Per named parameter, the derivative of the caller's clock origin (on the execution
    /// clock) with respect to it.
    pub d_origin: &'a [f64],
    /// The kind of the event that ends the run, at which the state is differentiated, and
    /// its name in the reasons.
    pub end: (EventKind, &'a str),
    /// Why the run did not end at that event, when it did not (the preset's words).
    pub not_ended: Option<String>,
    /// Report `z` and `ż` upwards (the execution's frame is NED: z down).
    pub z_up: bool,
}

/// The derivatives of the end body state along start-state directions and named parameters.
#[derive(Debug, Clone)]
pub struct EndStateSensitivity {
    /// `d_state[c][k] = d BODY_STATE_ENTRIES[c] / d names[k]`; NaN unless [`Self::ok`].
    pub d_state: Vec<Vec<f64>>,
    /// `d BODY_STATE_ENTRIES[c] / d (start-state direction j)`; NaN unless [`Self::ok`].
    pub d_state_d_start: Vec<Vec<f64>>,
    /// Whether every derivative is defined.
    pub ok: bool,
    /// Why not, when not ok.
    pub reason: Option<String>,
    /// One entry per event of the execution (times on the caller's clock).
    pub events: Vec<EventSaltation>,
    /// The behaviour's time events met: `(t_s, max |f⁺ − f⁻|)` on the caller's clock.
    pub time_events: Vec<(f64, f64)>,
    /// `d t_e / d (directions, names)` of each event's time on the caller's clock, in the
    /// order of [`Self::events`]; `None` where its saltation is not defined.
    pub event_times: Vec<Option<Vec<f64>>>,
}

/// Differentiates the body state at the event that ends `r.exec` (see [`EndStateRequest`]):
/// never an error; an undefined derivative makes the result not ok, with the reason: the
/// sensitivities' own failure, the run not ending at the event, an event without a defined
/// saltation ([`undefined_reason`]), the end event without a time gradient, or a derivative
/// that is not finite.
pub fn end_state_sensitivity(r: &EndStateRequest<'_>) -> EndStateSensitivity {
    let (nd, np, rows) = (
        r.directions.ncols(),
        r.named.len(),
        BODY_STATE_ENTRIES.len(),
    );
    let nan = |n: usize| vec![vec![f64::NAN; n]; rows];
    let mut out = EndStateSensitivity {
        d_state: nan(np),
        d_state_d_start: nan(nd),
        ok: false,
        reason: None,
        events: Vec::new(),
        time_events: Vec::new(),
        event_times: Vec::new(),
    };
    let s = match named_sensitivity_columns(r.model, r.terrain, r.exec, r.directions, r.named) {
        Ok(s) => s,
        Err(e) => {
            out.reason = Some(e.to_string());
            return out;
        }
    };
    out.events = event_saltations(&s, r.offset_s);
    let d_origin = |j: usize| if j >= nd { r.d_origin[j - nd] } else { 0.0 };
    out.event_times = s
        .event_time_columns
        .iter()
        .map(|c| {
            c.as_ref()
                .map(|c| (0..c.len()).map(|j| c[j] - d_origin(j)).collect())
        })
        .collect();
    out.time_events = time_event_jumps(&s, r.offset_s);
    if let Some(why) = r
        .not_ended
        .clone()
        .or_else(|| undefined_reason(&s, r.offset_s))
    {
        out.reason = Some(why);
        return out;
    }
    let x = s
        .columns
        .as_ref()
        .expect("defined where no reason is given");
    let Some(dt) = end_event_time_gradient(&s, r.exec, r.end.0) else {
        out.reason = Some(format!("the {} event has no time gradient", r.end.1));
        return out;
    };
    let model = r.model;
    let nq = model.nq();
    let (ix, iz, ip) = (model.ix_x(), model.ix_z(), model.ix_phi());
    let up = |v: f64| if r.z_up { -v } else { v };
    let column = |j: usize| -> [f64; 7] {
        [
            dt[j] - d_origin(j),
            x[(ix, j)],
            up(x[(iz, j)]),
            x[(ip, j)],
            x[(nq + ix, j)],
            up(x[(nq + iz, j)]),
            x[(nq + ip, j)],
        ]
    };
    for k in 0..np {
        for (c, v) in column(nd + k).into_iter().enumerate() {
            out.d_state[c][k] = v;
        }
    }
    for j in 0..nd {
        for (c, v) in column(j).into_iter().enumerate() {
            out.d_state_d_start[c][j] = v;
        }
    }
    // a derivative that a controller's partials leave undefined comes out NaN: never reported
    if let Some(k) = (0..np).find(|&k| out.d_state.iter().any(|c| !c[k].is_finite())) {
        out.reason = Some(format!("d/d{} is not finite", r.names[k]));
        out.d_state = nan(np);
        out.d_state_d_start = nan(nd);
        return out;
    }
    out.ok = true;
    out
}
