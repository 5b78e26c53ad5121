//! Samples of an execution on a uniform time grid, from its own dense output: each sample
//! evaluates the segment that contains it with the flow that segment ran with — its
//! controller ([`selfmanip_hybrid::Segment::controller`]), its locked joints and its sliding
//! contacts' directions — so the torques and contact forces are those of the run, with no
//! replay of the execution, and the sampler and the engine cannot disagree on a segment.
//!
//! ```text
//! t  => the last segment with t0 ≤ t => y = [q; q̇] on its dense output
//!    => the segment's flow (5.48): τ = controller(t, q, q̇, mode), free joints' q̈ => (q̈, λ)
//!    => contact points and world forces (λ along each active row's direction, plus the
//!       kinetic friction of sliding contacts along their tangent)
//! ```
use crate::error::{invalid, positive, SimError};
use crate::labels::ContactLabels;
use selfmanip_core::contact::{contact_geometry, row_direction};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{ContactMode, Data, Model, RowDirection, Terrain};
use selfmanip_hybrid::flow::FlowWorkspace;
use selfmanip_hybrid::Execution;
use serde::Serialize;

/// A vector per contact site (description order), world NED `[x, z]`; `None` where the site
/// has none.
pub type SiteVectors = Vec<Option<[f64; 2]>>;

/// The sample interval of logs and plots when the caller gives none (s): 200 samples a
/// second, finer than a stance of a few tens of milliseconds needs to show its shape.
pub const DEFAULT_DT_S: f64 = 0.005;

/// The most samples a trajectory holds: 10⁷ samples of a few coordinates are about a
/// gigabyte once they reach Python; the bound is checked before any is taken
/// (`dt = 1e-12` asked for terabytes).
pub const MAX_TRAJECTORY_SAMPLES: usize = 10_000_000;

/// Samples of an execution, for logs and plots.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Trajectory {
    /// Names of the coordinates of `q` (joints, then `x`, `z`, `phi`).
    pub q_names: Vec<String>,
    /// Contact names, the column order of `contact_points_m` / `contact_forces_n`.
    pub contacts: Vec<String>,
    /// Sample times (s; the execution clock minus the caller's offset).
    pub t_s: Vec<f64>,
    /// `q = [θ…, x, z, φ]` (NED: z down).
    pub q: Vec<Vec<f64>>,
    pub qd: Vec<Vec<f64>>,
    /// Joint torques `Υ` (N m), or empty when not sampled.
    pub tau: Vec<Vec<f64>>,
    /// Contact-mode label at each sample.
    pub mode: Vec<String>,
    /// World contact point `(x, z)` (NED) of each active contact, `None` when inactive.
    pub contact_points_m: Vec<Vec<Option<[f64; 2]>>>,
    /// World force `(f_x, f_z)` (NED) of the ground on the robot at each active contact.
    pub contact_forces_n: Vec<Vec<Option<[f64; 2]>>>,
}

/// Names of the coordinates of `model`'s `q`: `<joint>_theta` per joint (joint names as in
/// [`crate::labels::joint_name`]), then `x`, `z`, `phi`.
pub fn q_names(model: &Model) -> Vec<String> {
    let mut v: Vec<String> = (0..model.n_joints())
        .map(|j| format!("{}_theta", crate::labels::joint_name(model, j)))
        .collect();
    v.extend(["x", "z", "phi"].map(String::from));
    v
}

/// The indices into `q` of the coordinates `names` ([`q_names`]); an unknown name is an error
/// naming `field[i]` and listing the coordinates.
pub fn coordinate_indices(
    model: &Model,
    field: &str,
    names: &[String],
) -> Result<Vec<usize>, SimError> {
    let all = q_names(model);
    names
        .iter()
        .enumerate()
        .map(|(i, n)| {
            all.iter().position(|a| a == n).ok_or_else(|| {
                invalid(
                    format!("{field}[{i}]"),
                    format!("no coordinate `{n}` (coordinates: {})", all.join(", ")),
                )
            })
        })
        .collect()
}

/// Samples `exec` every `dt_s` seconds of its clock from 0 (and at its end); reported times
/// are `t − time_offset_s`; modes are labelled by `labels`.
pub fn sample(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    labels: &ContactLabels,
    dt_s: f64,
    time_offset_s: f64,
) -> Result<Trajectory, SimError> {
    sample_labelled(
        model,
        terrain,
        exec,
        &|m| labels.label(m),
        dt_s,
        time_offset_s,
    )
}

/// [`sample`] with the modes labelled by `label` (a robot's own notation, such as RHex's
/// `FB FL RB RL`).
pub fn sample_labelled(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    label: &dyn Fn(ContactMode) -> String,
    dt_s: f64,
    time_offset_s: f64,
) -> Result<Trajectory, SimError> {
    positive("dt_s", dt_s)?;
    let t_end = exec.t;
    let samples = (t_end / dt_s).floor();
    if samples.is_nan() || samples >= MAX_TRAJECTORY_SAMPLES as f64 {
        return Err(SimError::InvalidValue {
            field: "dt_s".into(),
            reason: format!(
                "{dt_s:e} s over the run's {t_end:.6} s is more than the \
                 {MAX_TRAJECTORY_SAMPLES} samples a trajectory holds"
            ),
        });
    }
    let nq = model.nq();
    let mut out = Trajectory {
        q_names: q_names(model),
        contacts: model.contacts.iter().map(|c| c.name.clone()).collect(),
        t_s: Vec::new(),
        q: Vec::new(),
        qd: Vec::new(),
        tau: Vec::new(),
        mode: Vec::new(),
        contact_points_m: Vec::new(),
        contact_forces_n: Vec::new(),
    };
    let mut ws = FlowWorkspace::new(model);
    let mut y = vec![0.0; 2 * nq];
    let n = samples.max(0.0) as usize;
    let times = (0..=n)
        .map(|k| k as f64 * dt_s)
        .chain((t_end > n as f64 * dt_s).then_some(t_end));
    for t in times {
        // the last segment that contains t: a reset at t belongs to the segment after it, even
        // one of zero duration (a run that ends at its final time right after an event ends
        // in the mode and the state after the reset, not in the slide or stance before it)
        let Some(seg) = exec.segments.iter().rev().find(|s| s.t0 <= t) else {
            continue;
        };
        seg.eval(t.min(seg.t1), &mut y);
        let (q, qd) = y.split_at(nq);
        // the segment's flow as it ran: its controller, its joints locked for a passage, its
        // sliding contacts' directions => (Υ, q̈, λ)
        ws.data.locked.clone_from(&seg.locked);
        ws.data.slide_directions.clone_from(&seg.slide_directions);
        ws.prepare(model, terrain, &*seg.controller, (t, seg.mode), q, qd)?;
        ws.solve_prepared(model, &*seg.controller, t, seg.mode, q, qd)?;
        let (points, forces) = site_points_and_forces(model, terrain, &ws.data, seg.mode);
        out.t_s.push(t - time_offset_s);
        out.q.push(q.to_vec());
        out.qd.push(qd.to_vec());
        out.tau.push(ws.tau.clone());
        out.mode.push(label(seg.mode));
        out.contact_points_m.push(points);
        out.contact_forces_n.push(forces);
    }
    Ok(out)
}

/// One vector per contact site of `model` (description order), in the world NED frame
/// `[x, z]`: the sum over the rows of `mode` of each row's value along the row's direction at
/// the kinematics `kin` (`λ` gives the ground's force on the robot, an impulse `P_λ` its
/// impulse); `None` for a site without a row.
pub fn site_vectors(
    model: &Model,
    terrain: &dyn Terrain,
    kin: &Kinematics,
    mode: ContactMode,
    rows: &[f64],
) -> SiteVectors {
    let mut out = vec![None; model.n_contacts()];
    for (r, &value) in mode.rows().zip(rows) {
        let geom = contact_geometry(model, kin, terrain, r.contact);
        let dir = row_direction(&geom.plane, r.direction);
        let v = out[r.contact].get_or_insert([0.0, 0.0]);
        v[0] += value * dir.x;
        v[1] += value * dir.y;
    }
    out
}

/// The world contact points `[x, z]` (m) and forces `[f_x, f_z]` (N, NED; the ground on the
/// robot) of each contact site of `model` in `mode`, from a flow solved in `data` (its `λ`
/// along each active row's direction, plus the kinetic friction of sliding contacts along
/// their tangent, outside the rows); `None` for a site not in `mode`.
pub fn site_points_and_forces(
    model: &Model,
    terrain: &dyn Terrain,
    data: &Data,
    mode: ContactMode,
) -> (SiteVectors, SiteVectors) {
    let mut forces = site_vectors(model, terrain, &data.kin, mode, data.lambda.as_slice());
    let mut points = vec![None; model.n_contacts()];
    for k in mode.active() {
        let geom = contact_geometry(model, &data.kin, terrain, k);
        points[k] = Some([geom.point.x, geom.point.y]);
    }
    for site in &data.sliding {
        let k = data.constraints.rows[site.row].contact;
        let geom = contact_geometry(model, &data.kin, terrain, k);
        let tangent = row_direction(&geom.plane, RowDirection::Tangential);
        if let Some(f) = forces[k].as_mut() {
            f[0] += site.force_t * tangent.x;
            f[1] += site.force_t * tangent.y;
        }
    }
    (points, forces)
}
