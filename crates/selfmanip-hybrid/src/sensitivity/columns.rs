//! The sensitivities along selected columns ([`execution_sensitivity_columns`]): directions
//! of the initial state and named parameters, carried as the augmented state's tangent
//! through every segment's flow and every event, never forming the full matrices.
use super::chain::{chain_complete, has_event_memory, EventChain};
use super::evaluator::{controller_names, Evaluator, FlowPoint};
use super::event_saltation::{segment_event, EventParts};
use super::force_events::force_guard_gradient;
use super::reset_jacobian::NotDifferentiated;
use super::segment_tangent::segment_flow;
use super::tangent::Tangent;
use super::truncation::{dwell_end, not_differentiated, reason_after, truncation_defined};
use super::types::{ColumnSensitivity, Parameter, SaltationStatus, SensitivityError};
use crate::contact_set::rows_of;
use crate::event::{Event, EventKind};
use crate::execution::{Execution, Segment};
use nalgebra::{DMatrix, RowDVector};
use selfmanip_core::contact::{contact_geometry, ContactKind};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::BodyParameter;
use selfmanip_core::{Model, Terrain};

/// The sensitivities of a recorded execution along the columns of `directions` (`2nq × d`,
/// directions of the initial state; `d` may be 0) and to the named `params`, propagated
/// without forming the full `2nq × 2nq` matrices along the flows (see the module docs). With
/// the augmented state `x̃ = (x, p)`, `ṗ = 0`:
///
/// - along a flow `Ẋ_p = F X_p + ∂f/∂p` (`∂f/∂p` from the controller's
///   [`Controller::parameter_partials`] through `∂q̈/∂Υ`, or from `∂(M̄q̈ + C̄q̇ + N̄)/∂p` for the
///   body's and links' inertia parameters, by implicit differentiation of the KKT system);
/// - at an event, `X⁺ = Ξ X + [0 | D_pR + (f⁺ − D_xR f⁻) D_pg / (D_xg f⁻)]`, and
///   `dt_e/d(columns) = −(D_xg X⁻ + [0 | D_pg]) / (D_xg f⁻)` (`D_pg` of a force guard from
///   `∂λ/∂p`; `D_pR` of a plastic impact from `∂M̄/∂p`);
/// - at a controller's time event `t_b(p)` where the flow jumps, `X_p += (f⁻ − f⁺) dt_b/dp`.
pub fn execution_sensitivity_columns(
    model: &Model,
    terrain: &dyn Terrain,
    exec: &Execution,
    directions: &DMatrix<f64>,
    params: &[Parameter],
) -> Result<ColumnSensitivity, SensitivityError> {
    let n2 = 2 * model.nq();
    let nd = directions.ncols();
    let m = nd + params.len();
    let body: Vec<BodyParameter> = params
        .iter()
        .filter_map(|p| match p {
            Parameter::Body(b) => Some(*b),
            _ => None,
        })
        .collect();
    for b in &body {
        b.check(model)?;
    }
    for p in params {
        check_friction(model, exec, p)?;
    }
    let mut ev = Evaluator::new(model, terrain);
    ev.memory_mode = has_event_memory(exec);
    let mut out = ColumnSensitivity {
        n_directions: nd,
        parameters: params.to_vec(),
        events: Vec::new(),
        event_time_columns: Vec::new(),
        touch_switches: Vec::new(),
        time_events: Vec::new(),
        feature_changes: Vec::new(),
        columns: None,
    };
    let mut x0 = DMatrix::zeros(n2, m);
    if nd > 0 {
        x0.columns_mut(0, nd).copy_from(directions);
    }
    let mut tangent = Tangent::Columns {
        x: x0,
        params,
        names: controller_names(params),
    };
    let mut chain = EventChain::new();
    // the time row of the latest truncation, which its dwell's end moves with
    let mut truncated: Option<RowDVector<f64>> = None;
    for (si, seg) in exec.segments.iter().enumerate() {
        segment_flow(
            &mut ev,
            seg,
            &mut tangent,
            &mut out.touch_switches,
            &mut out.time_events,
        )?;
        let ending = chain.ending(exec, si, &mut out.feature_changes);
        if exec.dwell_ends.contains(&seg.t1) {
            // a truncation's dwell ended by its length: a time event (super::truncation)
            let Tangent::Columns { x, .. } = &mut tangent else {
                unreachable!("columns stay columns")
            };
            let r = dwell_end(&mut ev, exec, si, (ending, truncated.as_ref()), x)?;
            if r.is_err() {
                chain.defined = false;
            }
            if let Some(e) = ending {
                if r.is_err() && ev.memory_mode {
                    ev.memory.push(DMatrix::from_element(1 + n2, m, f64::NAN));
                }
                out.event_time_columns
                    .push(truncated.clone().filter(|_| r.is_ok()));
                out.events.push(match r {
                    Ok(()) => truncation_defined(e, n2),
                    Err(NotDifferentiated(why)) => not_differentiated(e, why),
                });
            }
            continue;
        }
        let Some(event) = ending else {
            continue;
        };
        let trunc = chain.truncation(exec, event);
        let (mut es, parts) = segment_event(&mut ev, exec, si, (event, trunc), &body)?;
        if let (Some(xi), Some(first)) = (&es.saltation, es.one_sided.first()) {
            // several guards at once whose orders agree: the initial-state directions go
            // through its saltation; parameters and memory are not carried across it yet
            let Tangent::Columns { x, .. } = &mut tangent else {
                unreachable!("columns stay columns")
            };
            if params.is_empty() && !ev.memory_mode {
                out.event_time_columns.push(Some(&first.time_row * &*x));
                *x = xi * &*x;
                out.events.push(es);
                continue;
            }
            es.status = SaltationStatus::Unsupported {
                reason: "parameter columns and event memory through several guards at once \
                         are not carried yet"
                    .into(),
            };
        }
        let (Some(xi), Some(parts), Some(dg)) = (&es.saltation, parts, &es.guard_gradient) else {
            chain.defined = false;
            truncated = None;
            let told = 1 + usize::from(trunc.is_some());
            if ev.memory_mode && event.kind != EventKind::Apex {
                // the event's memory has no derivative: the run's columns are not returned
                for _ in 0..told {
                    ev.memory.push(DMatrix::from_element(1 + n2, m, f64::NAN));
                }
            }
            let reason = reason_after(&es);
            out.event_time_columns.push(None);
            out.events.push(es);
            if let Some(z) = trunc {
                out.event_time_columns.push(None);
                out.events.push(not_differentiated(z, reason));
            }
            continue;
        };
        let Tangent::Columns { x, .. } = &mut tangent else {
            unreachable!("columns stay columns")
        };
        let time = event_columns(&mut ev, (seg, event), (xi, parts, dg), x, params)?;
        out.event_time_columns.push(Some(time.clone()));
        out.events.push(es);
        if let Some(z) = trunc {
            // the truncation's saltation is the pair's, taken above
            out.event_time_columns.push(Some(time.clone()));
            out.events.push(truncation_defined(z, n2));
            truncated = Some(time);
        }
    }
    // a controller's time event moves the parameter columns only (its instant does not
    // depend on the state), so only this path needs its statuses
    let time_events_defined = out
        .time_events
        .iter()
        .all(|e| e.status == SaltationStatus::Defined);
    if chain.defined
        && time_events_defined
        && chain_complete(exec, chain.next_event, &out.touch_switches)
    {
        let Tangent::Columns { x, .. } = tangent else {
            unreachable!("columns stay columns")
        };
        out.columns = Some(x);
    }
    Ok(out)
}

/// The columns across an event whose saltation `xi` is defined (with its `parts` and guard
/// gradient `dg`): `x ← Ξ x + [0 | D_pR + (f⁺ − D_xR f⁻) D_pg / ġ]` (and the memory's terms),
/// the event remembered by the controllers when they remember events; returns
/// `dt_e/d(columns)`.
fn event_columns(
    ev: &mut Evaluator,
    (seg, event): (&Segment, &Event),
    (xi, parts, dg): (&DMatrix<f64>, EventParts, &RowDVector<f64>),
    x: &mut DMatrix<f64>,
    params: &[Parameter],
) -> Result<RowDVector<f64>, SensitivityError> {
    let (model, n2, m) = (ev.model, x.nrows(), x.ncols());
    let nd = m - params.len();
    // D_pg: a force guard's from ∂λ/∂p at the state before; a touchdown's and a stick's from
    // the geometric parameters that move their contact
    let mut dpg = RowDVector::zeros(m);
    if matches!(event.kind, EventKind::Liftoff | EventKind::Slip)
        && (!params.is_empty() || ev.memory_mode)
    {
        let k = event.triggered[0];
        let (rt, rn) = rows_of(seg.mode, k);
        let zero = DMatrix::zeros(n2, m);
        let c = ev.eval_columns(FlowPoint::on(seg, event.t, &parts.y_minus), &zero, params)?;
        if let Some(g) = rn.and_then(|rn| {
            force_guard_gradient(model, event.kind, k, (rt, rn), &c.lambda, &c.dlambda)
        }) {
            dpg = g;
        }
        if let (EventKind::Slip, Some(rn)) = (event.kind, rn) {
            // the slip guard `g = μ(−λ_n) − |λ_t|` moves with its own static μ:
            // `∂g/∂μ = −λ_n` at the state before
            for (i, p) in params.iter().enumerate() {
                if let Parameter::Friction {
                    contact,
                    coefficient,
                } = p
                {
                    if *contact == k && coefficient.moves_static() {
                        dpg[nd + i] -= c.lambda[rn];
                    }
                }
            }
        }
    }
    geometric_guard_partials(ev, event, &parts.y_minus, params, &mut dpg);
    let dgx = dg * &*x;
    let time = -(&dgx + &dpg) / parts.den;
    let jump = &parts.f_plus - &parts.dr * &parts.f_minus;
    let mut xn = xi * &*x;
    let mut bi = 0;
    for (k, p) in params.iter().enumerate() {
        let col = nd + k;
        if let Parameter::Body(_) = p {
            xn.column_mut(col).axpy(1.0, &parts.dr_p.column(bi), 1.0);
            bi += 1;
        }
        if dpg[col] != 0.0 {
            xn.column_mut(col).axpy(dpg[col] / parts.den, &jump, 1.0);
        }
        // a Coulomb impact's reset moves with the static μ of its slipping contacts
        if let Parameter::Friction {
            contact,
            coefficient,
        } = p
        {
            for (_, d) in parts.dr_mu.iter().filter(|(c, _)| c == contact) {
                if coefficient.moves_static() {
                    xn.column_mut(col).axpy(1.0, d, 1.0);
                }
            }
        }
    }
    if ev.memory_mode {
        // the guard moves with the memory too (a force guard's `∂λ/∂m Dm`), in the
        // directions' columns as in the parameters'
        for col in 0..nd {
            if dpg[col] != 0.0 {
                xn.column_mut(col).axpy(dpg[col] / parts.den, &jump, 1.0);
            }
        }
        if let Some(first) = &parts.first {
            // the event before a truncation taken at once, as the controller remembers it:
            // `Dx₁⁺ = D_xR₁ (X⁻ + f⁻ Dt_e) + D_pR₁` (super::truncation)
            let mut d = DMatrix::zeros(1 + n2, m);
            d.row_mut(0).copy_from(&time);
            let mut moved = &first.dr * (&*x + &parts.f_minus * &time);
            let mut bi = 0;
            for (k, p) in params.iter().enumerate() {
                if let Parameter::Body(_) = p {
                    moved
                        .column_mut(nd + k)
                        .axpy(1.0, &first.dr_p.column(bi), 1.0);
                    bi += 1;
                }
            }
            d.rows_mut(1, n2).copy_from(&moved);
            ev.memory.push(d);
        }
        if event.kind != EventKind::Apex {
            // the event as the controller remembers it: `(t_e, x⁺)` with
            // `Dx⁺ = X⁺ + f⁺ Dt_e` (X⁺ is the tangent at a fixed time just after it)
            let mut d = DMatrix::zeros(1 + n2, m);
            d.row_mut(0).copy_from(&time);
            let moved = &xn + &parts.f_plus * &time;
            d.rows_mut(1, n2).copy_from(&moved);
            ev.memory.push(d);
        }
    }
    *x = xn;
    Ok(time)
}

/// Whether a [`Parameter::Friction`] is one of `model`'s that the run can be differentiated
/// in: its contact exists; a static `μ` belongs to a sticking contact (a frictionless one
/// has none); a kinetic `μ_k` is positive wherever the contact slides along the run (at
/// `μ_k = 0` the sliding sites carry no friction and no direction, Assumption 5.9, so the
/// derivative there — one-sided in the direction's sign — is not formed).
fn check_friction(model: &Model, exec: &Execution, p: &Parameter) -> Result<(), SensitivityError> {
    let Parameter::Friction {
        contact,
        coefficient,
    } = *p
    else {
        return Ok(());
    };
    let bad = |reason: &str| {
        Err(SensitivityError::NotAParameter {
            parameter: p.clone(),
            reason: reason.to_string(),
        })
    };
    let Some(c) = model.contacts.get(contact) else {
        return bad("no such contact");
    };
    if coefficient.moves_static() && !matches!(c.friction, Friction::Sticking { .. }) {
        return bad("a frictionless contact has no static friction coefficient");
    }
    let slides = exec
        .segments
        .iter()
        .any(|s| s.mode.kind(contact) == Some(ContactKind::Slide));
    if coefficient.moves_kinetic() && c.kinetic_mu == 0.0 && slides {
        return bad(
            "the contact slides with no kinetic friction (mu_kinetic = 0); the derivative \
             at 0 is not formed",
        );
    }
    Ok(())
}

/// `dpg += D_pg` of a touchdown's height guard and a stick's sliding-velocity guard in the
/// geometric parameters among `params` that move the event's contact
/// (`selfmanip_core::geometry_partials`), at the state `y` just before the event.
fn geometric_guard_partials(
    ev: &Evaluator,
    event: &Event,
    y: &[f64],
    params: &[Parameter],
    dpg: &mut RowDVector<f64>,
) {
    let nd = dpg.len() - params.len();
    let geometric = |p: &Parameter| matches!(p, Parameter::Body(b) if b.is_geometric());
    if !matches!(event.kind, EventKind::Touchdown | EventKind::Stick)
        || !params.iter().any(geometric)
    {
        return;
    }
    let model = ev.model;
    let (q, qd) = y.split_at(model.nq());
    let mut kin = Kinematics::default();
    kin.compute(model, q, qd);
    let k = event.triggered[0];
    let geo = contact_geometry(model, &kin, ev.terrain, k);
    for (i, p) in params.iter().enumerate() {
        let Parameter::Body(b) = p else { continue };
        if !b.is_geometric() {
            continue;
        }
        dpg[nd + i] += match event.kind {
            EventKind::Touchdown => b.height_partial(model, &kin, k, geo.plane.normal()),
            _ => b.sliding_velocity_partial(model, &kin, k, geo.plane.tangent()),
        };
    }
}
