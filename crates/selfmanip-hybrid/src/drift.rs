//! Constraint drift: the flow (5.48) holds the active contacts on their surfaces at the
//! acceleration level only, `A q̈ + Ȧ q̇ = 0`, so the integrator's error lets the gaps
//! `a_k(q)` and the constraint velocities `A q̇` drift from zero. At the default tolerances
//! the drift stays orders of magnitude below [`TERRAIN_STEP_M`], the distance at which a
//! contact counts as having left its surface ([`crate::features`]); at coarse tolerances
//! (`rtol = 1e-3`) it reaches it within a fraction of a second and a flat-ground leap would
//! end as a terrain discontinuity.
//!
//! A contact off its surface by more than `TERRAIN_STEP_M` but no more than [`MAX_DRIFT_M`],
//! on the same feature, has drifted (a terrain step moves it onto another feature or by the
//! step's height): the state is projected back onto the constraints of its mode — the
//! positions by Newton steps on `a(q) = 0` in the metric of `M̄`,
//! $$ \begin{bmatrix} \bar M & A^T \\ A & 0 \end{bmatrix}
//!    \begin{bmatrix} \Delta q \\ \mu \end{bmatrix} = \begin{bmatrix} 0 \\ -a(q) \end{bmatrix}, $$
//! the velocities as a plastic impact into the mode, $\dot q^+ = \dot q - A^{\dagger T} A \dot q$
//! (5.52) — and the integration goes on from there.
use crate::flow::{Flow, FlowWorkspace};
use crate::surface_tolerances::{MAX_DRIFT_M, TERRAIN_STEP_M};
use selfmanip_core::contact::{ContactGeometry, RowDirection};
use selfmanip_core::{plastic_impact_prepared, ContactMode, CoreError};

/// Newton steps of the position projection (each squares the relative error of a gap of
/// `MAX_DRIFT_M` on curvatures of the robot's size).
const NEWTON_STEPS: usize = 3;

/// Whether active contact `k`, whose geometry at the segment's start was `start` and is
/// `now`, has drifted (same feature, off by at most [`MAX_DRIFT_M`], or by at most that
/// much more than at the start) rather than left its surface. A touchdown located to
/// `event_tol_s` starts its segment up to `|ȧ_k| event_tol_s` below the ground (the reset
/// accepts that much, `crate::reset`): at a coarse tolerance and a fast leg that is more
/// than `MAX_DRIFT_M`, and it is the location's error, not a step of the terrain.
pub fn drifted(start: &ContactGeometry, now: &ContactGeometry) -> bool {
    now.same_feature(start)
        && (now.gap_m.abs() <= MAX_DRIFT_M || (now.gap_m - start.gap_m).abs() <= MAX_DRIFT_M)
}

/// Projects `y = [q; q̇]` onto the constraints of `mode` at time `t` (see the module docs),
/// on the workspace `ws`; `flow` gives the geometry and the controller is not needed.
pub fn project(
    flow: &mut Flow,
    ws: &mut FlowWorkspace,
    mode: ContactMode,
    y: &mut [f64],
) -> Result<(), CoreError> {
    let model = flow.model();
    let terrain = flow.terrain();
    let nq = model.nq();
    let data = &mut ws.data;
    data.locked.clear();
    data.locked.extend_from_slice(flow.lock());
    for _ in 0..NEWTON_STEPS {
        let (q, qd) = y.split_at(nq);
        data.prepare(model, terrain, mode, q, qd)?;
        // A Δq = −a on the normal rows (gap a_k), 0 on the tangential rows (a sticking
        // contact keeps its point)
        let c = data.constraints.n_rows();
        let mut g = vec![0.0; c];
        let mut worst: f64 = 0.0;
        for (r, row) in data.constraints.rows.iter().enumerate() {
            if row.direction == RowDirection::Normal {
                let gap = flow.geometry(row.contact, y).gap_m;
                g[r] = -gap;
                worst = worst.max(gap.abs());
            }
        }
        if worst <= 1e-3 * TERRAIN_STEP_M {
            break;
        }
        let m = data.dynamic_coords.len();
        let (f, mut x, mut mu) = (vec![0.0; m], vec![0.0; m], vec![0.0; c]);
        data.kkt.solve(&f, &g, &mut x, &mut mu);
        for (i, &a) in data.dynamic_coords.iter().enumerate() {
            y[a] += x[i];
        }
    }
    // A q̇ = 0 at the projected configuration
    let (q, qd) = y.split_at(nq);
    data.prepare(model, terrain, mode, q, qd)?;
    let imp = plastic_impact_prepared(model, data, qd)?;
    y[nq..].copy_from_slice(imp.qd_plus.as_slice());
    Ok(())
}
