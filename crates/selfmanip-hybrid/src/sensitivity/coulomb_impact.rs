//! A reset that is a Coulomb impact (`crate::coulomb_impact`: the plastic impact with every
//! candidate's impulse in its own cone, a jam's reset where the engine's own law has no
//! consistent outcome): the outcome among the impact's solutions that reproduces the
//! recorded `q̇⁺`, and its Jacobians on its active set
//! ([`crate::coulomb_impact::coulomb_impact_jacobian`]): `D_xR`, the body parameters' `D_pR`
//! and each slipping contact's `∂R/∂μ`.
use super::reset_jacobian::{EventAt, GuardReset, NotDifferentiated};
use crate::coulomb_impact::{coulomb_impact_jacobian, coulomb_impacts, NotDifferentiable};
use crate::event::max_diff;
use nalgebra::DVector;
use selfmanip_core::Data;

/// The Coulomb impact among the contacts of the mode before and those the event names
/// (`crate::jam::coulomb_jam`'s candidates) whose `q̇⁺` is the recorded one within `tol`,
/// with its Jacobians, into `gr`; or why there is none or it has no derivative.
pub(super) fn coulomb_reset(
    at: &EventAt,
    gr: &mut GuardReset,
    tol: f64,
) -> Result<(), NotDifferentiated> {
    let (model, event) = (at.model, at.event);
    let nq = model.nq();
    let (q, qd_minus) = (at.q(), at.qd_minus());
    let mut candidates: Vec<usize> = at
        .before
        .mode
        .active()
        .chain(event.triggered.iter().copied())
        .collect();
    candidates.sort_unstable();
    candidates.dedup();
    let mut data = Data::new(model);
    let not = |why: String| NotDifferentiated(format!("nor a Coulomb impact: {why}"));
    let outcomes = match coulomb_impacts(model, &mut data, at.terrain, &candidates, q, qd_minus) {
        Ok(Ok(o)) => o,
        Ok(Err(e)) => return Err(not(format!("not offered ({e:?})"))),
        Err(e) => return Err(not(e.to_string())),
    };
    let mismatch =
        |o: &&crate::coulomb_impact::CoulombImpact| max_diff(o.qd_plus.as_slice(), &event.qd_after);
    let Some(o) = outcomes.iter().find(|o| mismatch(o) <= tol) else {
        return Err(not(format!(
            "none of its {} solutions is the recorded q̇⁺",
            outcomes.len()
        )));
    };
    let jac = match coulomb_impact_jacobian(model, &mut data, at.terrain, o, q, qd_minus, at.body) {
        Ok(Ok(j)) => j,
        Ok(Err(NotDifferentiable::Boundary { contact, state })) => {
            return Err(not(format!(
                "contact {contact} is on the boundary of its state {state:?} (piecewise smooth \
                 there)"
            )))
        }
        Ok(Err(NotDifferentiable::Singular)) => {
            return Err(not("its active set's system is singular".into()))
        }
        Ok(Err(NotDifferentiable::GeometricParameter(p))) => {
            return Err(not(format!(
                "its column in the geometric parameter {p:?} is not formed"
            )))
        }
        Err(e) => return Err(not(e.to_string())),
    };
    gr.velocity_jump(
        (&jac.dqd_plus.dq, &jac.dqd_plus.dqd, &jac.dqd_plus_dbody),
        &o.qd_plus,
    );
    gr.dr_mu = jac
        .dqd_plus_dmu
        .into_iter()
        .filter(|(_, d)| d.iter().any(|v| *v != 0.0))
        .map(|(k, d)| {
            let mut col = DVector::zeros(2 * nq);
            col.rows_mut(nq, nq).copy_from(&d);
            (k, col)
        })
        .collect();
    gr.impact_mode = Some(o.mode);
    Ok(())
}
