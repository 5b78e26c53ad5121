//! The impulses and forces an event record carries (`selfmanip_sim::events`), in the one
//! presentation of contact forces (per contact site, world NED `[x, z]`, the ground on the
//! robot), checked on RHex leaps that push, slip, lift off, fly and land again against
//! routes that do not read them:
//! - an impact's impulses are its momentum jump, `Σ_k J_kᵀ p_k = M̄ (q̇⁺ − q̇⁻)`, with `J_k`
//!   the finite-difference Jacobian of the material point at site `k`'s contact point and
//!   `q̇⁻` the end of the segment before the event (Newton's law integrated over the impact);
//! - a slip's force lies on its kinetic cone's edge, `|f_x| = μ_k |f_z|` on level ground, and
//!   equals the sticking force just before it (`μ_k = μ` for these toes: Coulomb's force is
//!   continuous through the slip);
//! - a liftoff's leaving contact carried no normal force just before it (the guard), and the
//!   contacts kept carry the same force on both sides of it;
//! - the engine's own event forces (`selfmanip_hybrid::Event::force`, rows of the mode after,
//!   from the reset's complementarity) are the flow's forces the record shows;
//! - force events carry no impulse.
use nalgebra::{DVector, Matrix2, Vector2};
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LeapResult};
use rhex_model::Rhex;
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::kinematics::{Kinematics, Part};
use selfmanip_core::model::Friction;
use selfmanip_core::{ContactKind, FlatGround, Model};
use selfmanip_hybrid::flow::FlowWorkspace;
use selfmanip_hybrid::{Event, EventKind};
use selfmanip_sim::trajectory::{site_points_and_forces, site_vectors};
use selfmanip_sim::EventRecord;

/// Leaps of the four strategies that run on past their apex to land, and those that stop
/// there, each with the model it ran on.
fn leaps() -> Vec<(Model, LeapResult)> {
    let p = leap_params();
    let mut out = Vec::new();
    for s in ["++", "--", "+-", "-+"] {
        for (t2, stop_at_apex) in [(0.0, false), (0.1, false), (0.02, true)] {
            let cfg = LeapConfig {
                strategy: s.parse().unwrap(),
                t2_s: t2,
                stop_at_apex,
                ..LeapConfig::default()
            };
            let mut pp = p.clone();
            pp.pairs = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs()).to_vec();
            let model = Rhex::new(pp).unwrap().model;
            out.push((model, simulate_leap(&p, &cfg).unwrap()));
        }
    }
    out
}

/// The segment the run ended at event `e` (its left limit), and the state there.
fn before<'a>(r: &'a LeapResult, e: &Event) -> Option<(&'a selfmanip_hybrid::Segment, Vec<f64>)> {
    let seg = r
        .execution
        .segments
        .iter()
        .rev()
        .find(|s| s.t0 < e.t && s.t1 == e.t)?;
    let mut y = vec![0.0; 2 * e.q.len()];
    seg.eval(e.t, &mut y);
    Some((seg, y))
}

/// The forces per site of the flow of the segment that ended at `e`, at its end (the left
/// limit of the force at the event), through the trajectory's own evaluation.
fn force_before(model: &Model, r: &LeapResult, e: &Event) -> Option<Vec<Option<[f64; 2]>>> {
    let (seg, y) = before(r, e)?;
    let (q, qd) = y.split_at(model.nq());
    let mut ws = FlowWorkspace::new(model);
    ws.data.locked.clone_from(&seg.locked);
    ws.data.slide_directions.clone_from(&seg.slide_directions);
    ws.data
        .prepare(model, &FlatGround, seg.mode, q, qd)
        .unwrap();
    ws.solve_prepared(model, &*seg.controller, e.t, seg.mode, q, qd)
        .unwrap();
    Some(site_points_and_forces(model, &FlatGround, &ws.data, seg.mode).1)
}

/// Each event of `kind` in [`leaps`] with its model, its record and the forces per site just
/// before it ([`force_before`]), and the events of its run.
fn with_left_forces(
    kind: EventKind,
    mut check: impl FnMut(&Model, &Event, &EventRecord, &[Option<[f64; 2]>], &[Event]),
) {
    for (model, r) in leaps() {
        for (e, rec) in r.execution.events.iter().zip(&r.events) {
            if e.kind != kind {
                continue;
            }
            if let Some(left) = force_before(&model, &r, e) {
                check(&model, e, rec, &left, &r.execution.events);
            }
        }
    }
}

/// `Jᵀ p`: the generalized impulse of the world impulse `p` at the material point of `part`
/// at world position `point`, `J` by central differences of that point's position over `q`.
fn generalized(
    model: &Model,
    q: &[f64],
    part: Part,
    point: Vector2<f64>,
    p: [f64; 2],
) -> DVector<f64> {
    let nq = model.nq();
    let mut kin = Kinematics::default();
    kin.compute(model, q, &vec![0.0; nq]);
    // the point in the part's frame: the part's pose is affine in the local point
    let o = kin.point(part, Vector2::zeros());
    let r = Matrix2::from_columns(&[
        kin.point(part, Vector2::x()) - o,
        kin.point(part, Vector2::y()) - o,
    ]);
    let local = r.try_inverse().unwrap() * (point - o);
    let h = 1e-6;
    let mut out = DVector::zeros(nq);
    for i in 0..nq {
        let at = |s: f64| {
            let mut qq = q.to_vec();
            qq[i] += s;
            let mut k = Kinematics::default();
            k.compute(model, &qq, &vec![0.0; nq]);
            k.point(part, local)
        };
        let col = (at(h) - at(-h)) / (2.0 * h);
        out[i] = col.x * p[0] + col.y * p[1];
    }
    out
}

#[test]
fn impact_impulses_are_the_momentum_jump() {
    let mut checked = 0;
    for (model, r) in leaps() {
        for (i, (e, rec)) in r.execution.events.iter().zip(&r.events).enumerate() {
            assert_eq!(rec.impulse_n_s.len(), model.n_contacts());
            if !e.kind.is_impulsive() || e.impulse.is_empty() {
                // force events take no impulse
                assert!(rec.impulse_n_s.iter().all(Option::is_none), "{rec:?}");
                continue;
            }
            // q̇⁻: the previous event's q̇⁺ when it was at the same instant (a Zeno window's
            // last event and its truncation), else the end of the segment before
            let nq = model.nq();
            let y = match i.checked_sub(1).map(|j| &r.execution.events[j]) {
                Some(prev) if prev.t == e.t => [prev.q.clone(), prev.qd_after.clone()].concat(),
                _ => match before(&r, e) {
                    Some((_, y)) => y,
                    None => continue,
                },
            };
            let (q, qd_minus) = y.split_at(nq);
            let mut data = selfmanip_core::Data::new(&model);
            data.prepare_geometry(&model, &FlatGround, e.mode_after, q, qd_minus)
                .unwrap();
            let jump = &data.m_bar
                * (DVector::from_column_slice(&e.qd_after) - DVector::from_column_slice(qd_minus));
            let mut sum = DVector::zeros(nq);
            for (k, p) in rec.impulse_n_s.iter().enumerate() {
                if let Some(p) = p {
                    let geom = contact_geometry(&model, &data.kin, &FlatGround, k);
                    sum += generalized(&model, q, geom.part, geom.point, *p);
                }
            }
            let scale = jump.amax() + 1e-3;
            let err = (&sum - &jump).amax();
            assert!(
                err < 1e-5 * scale,
                "{:?} at {}: Σ Jᵀp = {sum} vs M̄Δq̇ = {jump} ({e:?}, {rec:?})",
                e.kind,
                e.t
            );
            checked += 1;
        }
    }
    assert!(checked >= 10, "only {checked} impacts checked");
}

#[test]
fn a_slip_force_is_on_the_kinetic_cone_and_continuous() {
    let mut checked = 0;
    with_left_forces(EventKind::Slip, |model, e, rec, left, _| {
        for &k in &e.triggered {
            if e.mode_after.kind(k) != Some(ContactKind::Slide) {
                continue;
            }
            let Friction::Sticking { mu } = model.contacts[k].friction else {
                panic!("only sticking contacts slip")
            };
            let mu_k = model.contacts[k].kinetic_mu;
            assert_eq!(mu_k, mu, "these toes slide with μ_k = μ");
            let f = rec.force_n[k].expect("a sliding contact carries a force");
            // level ground: x tangential, z normal (down: a push is negative)
            assert!(f[1] < 0.0, "the ground pushes: {f:?}");
            let cone = (f[0].abs() - mu_k * f[1].abs()).abs();
            assert!(
                cone < 1e-9 * f[1].abs(),
                "|f_t| − μ_k |f_n| = {cone} ({f:?})"
            );
            let l = left[k].expect("sticking before the slip");
            let jump = (f[0] - l[0]).hypot(f[1] - l[1]);
            assert!(jump < 1e-4 * f[1].abs() + 1e-6, "{l:?} -> {f:?}");
            checked += 1;
        }
    });
    assert!(checked >= 4, "only {checked} slips checked");
}

/// Whether contact `k`, let go at `e`, has been held since a Zeno truncation closed it: its
/// liftoff ends the truncation's dwell (`selfmanip_hybrid::zeno::dwell_end`), where the
/// contacts held are judged by force complementarity at once, not at a zero of their force.
fn held_since_a_truncation(events: &[Event], e: &Event, k: usize) -> bool {
    let i = events.iter().position(|x| std::ptr::eq(x, e)).unwrap();
    for x in events[..i].iter().rev() {
        if !x.mode_after.contains(k) {
            return false;
        }
        if !x.mode_before.contains(k) || x.kind == EventKind::ZenoTruncation {
            return x.kind == EventKind::ZenoTruncation;
        }
    }
    false
}

#[test]
fn a_liftoff_leaves_at_zero_normal_force_and_keeps_the_others() {
    let (mut checked, mut dwell_ends) = (0, 0);
    with_left_forces(EventKind::Liftoff, |model, e, rec, left, events| {
        let weight = model.total_mass_kg() * 9.81;
        let mut released = e
            .mode_before
            .active()
            .filter(|&k| !e.mode_after.contains(k));
        if released.any(|k| held_since_a_truncation(events, e, k)) {
            dwell_ends += 1;
            return;
        }
        for k in e.mode_before.active() {
            let l = left[k].expect("active before the liftoff");
            if e.mode_after.contains(k) {
                let f = rec.force_n[k].expect("kept");
                let jump = (f[0] - l[0]).hypot(f[1] - l[1]);
                assert!(jump < 1e-4 * weight, "kept {k}: {l:?} -> {f:?}");
            } else {
                assert!(rec.force_n[k].is_none(), "released {k}");
                assert!(l[1].abs() < 1e-5 * weight, "released {k} at {l:?}");
                checked += 1;
            }
        }
    });
    assert!(checked >= 4, "only {checked} liftoffs checked");
    println!("{checked} liftoffs at a zero of their force; {dwell_ends} ending a dwell");
}

/// The engine's event force (rows of the mode after, from the reset's complementarity) is
/// the force of the flow the run continued in (the record's): normal components at every
/// site, tangential ones at sticking sites (a sliding site's friction is outside the rows).
#[test]
fn engine_event_forces_are_the_flow_forces() {
    let mut checked = 0;
    for (model, r) in leaps() {
        let weight = model.total_mass_kg() * 9.81;
        for (e, rec) in r.execution.events.iter().zip(&r.events) {
            if e.force.is_empty() {
                continue;
            }
            let mut kin = Kinematics::default();
            kin.compute(&model, &e.q, &e.qd_after);
            let rows = site_vectors(&model, &FlatGround, &kin, e.mode_after, &e.force);
            assert_eq!(rows.len(), rec.force_n.len(), "{:?}", e.kind);
            for (k, (&row, &recorded)) in rows.iter().zip(&rec.force_n).enumerate() {
                match (row, recorded) {
                    (None, None) => {}
                    (Some(a), Some(b)) => {
                        let sticking = e.mode_after.kind(k) == Some(ContactKind::Stick);
                        let dx = if sticking { (a[0] - b[0]).abs() } else { 0.0 };
                        let d = dx.max((a[1] - b[1]).abs());
                        assert!(d < 1e-6 * weight, "{:?} site {k}: {a:?} vs {b:?}", e.kind);
                        checked += 1;
                    }
                    other => panic!("{:?} site {k}: {other:?}", e.kind),
                }
            }
        }
    }
    assert!(checked >= 20, "only {checked} sites checked");
}
