//! Terrain features under the active contacts. An active contact stays on the feature
//! (plane or convex corner) it had at the start of its segment — the flow holds its gap
//! $a_k(q) = 0$ there — or passes onto the next one continuously: a circle from a face onto
//! the edge at its top, and on over it onto the top, its gap and normal continuous. The
//! segment ends there (located to the event tolerance, the step taken again up to it, no
//! event) and the next one starts on the new feature. A contact that leaves its surface
//! otherwise (a point crossing an edge, any site reaching a concave corner, where it would
//! touch two surfaces) ends the execution with
//! [`crate::Termination::TerrainDiscontinuity`].
use crate::bracketing::bisect_first;
use crate::drift::drifted;
use crate::flow::Flow;
use crate::integrate::DenseStep;
use crate::surface_tolerances::{MAX_DRIFT_M, TERRAIN_STEP_M};
use selfmanip_core::contact::ContactGeometry;
use selfmanip_core::ContactMode;

/// Largest change of a contact's normal (a unit vector) across the event bracket at which
/// it passes onto the next terrain feature for the two to count as one continuous surface
/// (a face and its edge: the change is the turning over the bracket, ~1e-9; a concave
/// corner turns it by a right angle).
pub const FEATURE_NORMAL_TOL: f64 = 1e-6;

/// The feature each active contact of a segment is on at the segment's start.
#[derive(Debug, Default)]
pub struct Surfaces {
    on: Vec<(usize, ContactGeometry)>,
}

/// How a contact left its feature inside a step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FeatureChange {
    /// Onto the next feature of a continuous surface, at `t` (the late end of the bracket).
    Continuous { t: f64 },
    /// Off its surface at `t`: the terrain is discontinuous for it there.
    Discontinuity { t: f64, contact: usize, gap_m: f64 },
}

impl Surfaces {
    /// The features under the active contacts of `mode` at `y = [q; q̇]`.
    pub fn at_start(&mut self, flow: &mut Flow, mode: ContactMode, y: &[f64]) {
        self.on.clear();
        for k in mode.active() {
            let g = flow.geometry(k, y);
            self.on.push((k, g));
        }
    }

    /// An active contact that is no longer on its feature at `y`, with its geometry there:
    /// its height further than [`TERRAIN_STEP_M`] from zero (the surface ended under it: a
    /// point crossed a convex edge), or another feature is now nearer — the next face, the
    /// corner between two faces, or (at a concave corner, where one site would touch two
    /// surfaces) a face at an angle.
    pub fn left_by(&self, flow: &mut Flow, y: &[f64]) -> Option<(usize, ContactGeometry)> {
        self.on.iter().find_map(|(k, start)| {
            let g = flow.geometry(*k, y);
            (!g.same_feature(start) || g.gap_m.abs() > TERRAIN_STEP_M).then_some((*k, g))
        })
    }

    /// Whether every active contact that [`Self::left_by`] would report at `y` has only
    /// drifted off its surface ([`crate::drift`]), none left it.
    pub fn only_drifted(&self, flow: &mut Flow, y: &[f64]) -> bool {
        self.on.iter().all(|(k, start)| {
            let g = flow.geometry(*k, y);
            let off = !g.same_feature(start) || g.gap_m.abs() > TERRAIN_STEP_M;
            !off || drifted(start, &g)
        })
    }

    /// Where, in the step `dense` at whose end some contact is off its feature, the first
    /// contact leaves it (bisection to `tol` on the dense output, `y` as scratch), and
    /// whether it passes onto a continuing feature there.
    pub fn locate_change(
        &self,
        flow: &mut Flow,
        dense: &DenseStep,
        y: &mut [f64],
        tol: f64,
    ) -> FeatureChange {
        let (on, off) = bisect_first(
            &mut |t| {
                dense.eval(t, y);
                self.left_by(flow, y).is_some()
            },
            (dense.t0, dense.t1()),
            tol,
        );
        dense.eval(off, y);
        let (contact, after) = self.left_by(flow, y).expect("off its feature at `off`");
        dense.eval(on, y);
        let before = flow.geometry(contact, y);
        // the gap does not jump: on the ground, or (a contact that had drifted, e.g. started
        // below the ground by a coarsely located touchdown) as far off it as just before
        let gap_continuous = after.gap_m.abs() <= TERRAIN_STEP_M
            || ((after.gap_m - before.gap_m).abs() <= TERRAIN_STEP_M
                && after.gap_m.abs() <= MAX_DRIFT_M);
        let continuous = gap_continuous
            && (after.plane.normal() - before.plane.normal()).norm() <= FEATURE_NORMAL_TOL;
        if continuous {
            FeatureChange::Continuous { t: off }
        } else {
            FeatureChange::Discontinuity {
                t: off,
                contact,
                gap_m: after.gap_m,
            }
        }
    }
}
