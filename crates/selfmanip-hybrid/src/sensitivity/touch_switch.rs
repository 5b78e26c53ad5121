//! The saltation of a switch inside a segment between an active arc's rolling and its end's
//! point touch ([`TouchSwitch`]).
use super::evaluator::{Evaluator, FlowPoint};
use super::saltation::saltation;
use super::types::{SaltationStatus, SensitivityError, TouchSwitch};
use crate::execution::Segment;
use nalgebra::{DMatrix, RowDVector};
use selfmanip_core::contact::TouchKind;

/// The saltation of a rolling/point switch bracketed by `(t⁻, y⁻)`, `(t⁺, y⁺)`.
pub(super) fn touch_switch(
    ev: &mut Evaluator,
    seg: &Segment,
    (tm, ym): (f64, &[f64]),
    (tp, yp): (f64, &[f64]),
    before: &[(usize, TouchKind)],
) -> Result<TouchSwitch, SensitivityError> {
    let model = ev.model;
    let n2 = ym.len();
    let after = ev.touches(seg.mode, yp);
    let changed: Vec<usize> = before
        .iter()
        .zip(&after)
        .filter(|(a, b)| a != b)
        .map(|(a, _)| a.0)
        .collect();
    let mut sw = TouchSwitch {
        t: tp,
        contact: changed.first().copied().unwrap_or(usize::MAX),
        status: SaltationStatus::Defined,
        saltation: None,
    };
    if changed.len() != 1 {
        sw.status = SaltationStatus::Simultaneous;
        return Ok(sw);
    }
    let fm = ev.flow(FlowPoint::on(seg, tm, ym))?;
    let fp = ev.flow(FlowPoint::on(seg, tp, yp))?;
    // g = α_n − β_part(q) − α_end: D_qg = −∂β/∂q
    let mut dg = RowDVector::zeros(n2);
    dg[model.ix_phi()] = -1.0;
    if let Some(j) = model.contacts[sw.contact].link {
        for k in model.chain(j) {
            dg[k] = -model.joints[k].axis_sign;
        }
    }
    match saltation(&DMatrix::identity(n2, n2), &fm, &fp, &dg) {
        Ok(x) => sw.saltation = Some(x),
        Err(status) => sw.status = status,
    }
    Ok(sw)
}
