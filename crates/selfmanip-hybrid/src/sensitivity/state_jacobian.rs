//! The sensitivities of an execution to its initial state ([`execution_sensitivity`]): the
//! full `Φ` of each segment and the saltation of each event, chained.
use super::chain::{chain_complete, has_event_memory, EventChain};
use super::columns::execution_sensitivity_columns;
use super::evaluator::Evaluator;
use super::event_saltation::segment_event;
use super::reset_jacobian::NotDifferentiated;
use super::segment_tangent::segment_flow;
use super::tangent::Tangent;
use super::truncation::{dwell_end_flows, not_differentiated, reason_after, truncation_defined};
use super::types::{SaltationStatus, Sensitivity, SensitivityError};
use crate::controller::Controller;
use crate::execution::Execution;
use crate::options::HybridOptions;
use crate::simulate::simulate;
use nalgebra::{DMatrix, RowDVector};
use selfmanip_core::{ContactMode, Model, Terrain};

/// Runs [`simulate`] and then [`execution_sensitivity`] on its result. The execution is
/// the one [`simulate`] returns, bit for bit.
#[allow(clippy::too_many_arguments)]
pub fn simulate_with_sensitivity(
    model: &Model,
    terrain: &dyn Terrain,
    controller: &dyn Controller,
    mode0: ContactMode,
    q0: &[f64],
    qd0: &[f64],
    t_final: f64,
    opts: HybridOptions,
) -> Result<(Execution, Sensitivity), SensitivityError> {
    let exec = simulate(model, terrain, controller, mode0, q0, qd0, t_final, opts)?;
    let s = execution_sensitivity(model, terrain, &exec)?;
    Ok((exec, s))
}

/// The sensitivities of a recorded execution to its initial state (see the module docs).
/// Each segment is re-evaluated with the controller it ran with.
pub fn execution_sensitivity(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
) -> Result<Sensitivity, SensitivityError> {
    let n2 = 2 * model.nq();
    let mut ev = Evaluator::new(model, terrain);
    let mut out = Sensitivity {
        segment_flows: Vec::new(),
        events: Vec::new(),
        touch_switches: Vec::new(),
        feature_changes: Vec::new(),
        state_jacobian: None,
        one_sided_state_jacobian: None,
    };
    let mut total = DMatrix::identity(n2, n2);
    let mut chain = EventChain::new();
    let mut one_sided = false;
    // dt/dx(0) of the latest truncation, which its dwell's end moves with
    let mut truncated: Option<RowDVector<f64>> = None;
    for (si, seg) in exec.segments.iter().enumerate() {
        let mut tangent = Tangent::Full(DMatrix::identity(n2, n2));
        segment_flow(
            &mut ev,
            seg,
            &mut tangent,
            &mut out.touch_switches,
            &mut Vec::new(),
        )?;
        let Tangent::Full(phi) = tangent else {
            unreachable!("a full tangent stays full")
        };
        total = &phi * total;
        out.segment_flows.push(phi);
        let ending = chain.ending(exec, si, &mut out.feature_changes);
        if exec.dwell_ends.contains(&seg.t1) {
            // a truncation's dwell ended by its length: `+(f⁻ − f⁺) dt_trunc/dx(0)`
            // (super::truncation)
            let r = match &truncated {
                Some(tg) => dwell_end_flows(&mut ev, exec, si)?.map(|(fm, fp)| {
                    total += (fm - fp) * tg;
                }),
                None => Err(NotDifferentiated(
                    "the end of a dwell whose truncation was not differentiated".into(),
                )),
            };
            if r.is_err() {
                chain.defined = false;
            }
            if let Some(e) = ending {
                let mut es = match r {
                    Ok(()) => truncation_defined(e, n2),
                    Err(NotDifferentiated(why)) => not_differentiated(e, why),
                };
                es.time_gradient = truncated.clone().filter(|_| es.saltation.is_some());
                out.events.push(es);
            }
            continue;
        }
        let Some(event) = ending else {
            continue;
        };
        let trunc = chain.truncation(exec, event);
        let (mut es, parts) = segment_event(&mut ev, exec, si, (event, trunc), &[])?;
        if let (Some(dg), Some(parts)) = (&es.guard_gradient, &parts) {
            // `ġ = D_xg f⁻ (+ ∂g/∂t)` at the event, as its saltation had it
            es.time_gradient = Some(-(dg * &total) / parts.den);
        } else if let Some(first) = es.one_sided.first() {
            // several guards at once: the time of the one that fires first (in the first
            // order), the event's time
            es.time_gradient = Some(&first.time_row * &total);
        }
        match (&es.saltation, &es.status) {
            (Some(x), _) => total = x * total,
            (None, SaltationStatus::OneSided { .. }) => {
                one_sided = true;
                total = &es.one_sided[0].saltation * total;
            }
            _ => chain.defined = false,
        }
        if let Some(z) = trunc {
            // the truncation's saltation is the pair's, taken with the event before it
            let zs = match &es.saltation {
                Some(_) if es.one_sided.is_empty() => {
                    let mut zs = truncation_defined(z, n2);
                    zs.time_gradient = es.time_gradient.clone();
                    zs
                }
                _ => not_differentiated(z, reason_after(&es)),
            };
            truncated = zs.time_gradient.clone();
            out.events.push(es);
            out.events.push(zs);
            continue;
        }
        out.events.push(es);
    }
    // events not matched to a segment end, switches not differentiated
    if chain.defined && chain_complete(exec, chain.next_event, &out.touch_switches) {
        if one_sided {
            out.one_sided_state_jacobian = Some(total);
        } else {
            out.state_jacobian = Some(total);
        }
    }
    if has_event_memory(exec) {
        // the memory couples the segments: the chain is no longer the product of the
        // segments' flows and saltations (which hold it fixed); the columns carry it
        let cols =
            execution_sensitivity_columns(model, terrain, exec, &DMatrix::identity(n2, n2), &[])?;
        for (e, tc) in out.events.iter_mut().zip(cols.event_time_columns) {
            if e.time_gradient.is_some() {
                e.time_gradient = tc;
            }
        }
        out.state_jacobian = out.state_jacobian.and(cols.columns);
        // (the columns do not follow one-sided events)
        out.one_sided_state_jacobian = None;
    }
    Ok(out)
}
