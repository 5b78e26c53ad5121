//! A touchdown that would leave another toe on a slide with no consistent continuation
//! (Painlevé) is taken again with that toe sticking: a jam (`selfmanip_hybrid::jam`,
//! `docs/singular-transitions.md` section 7). On the leap of massless links that carry their
//! rotors (`leg_armature_kg_m2` = `n J G²` at 28:1, `docs/decisions/2026-11-24-massive-legs-carry-their-rotors.md`), (−,−) with the
//! middle motor 0.1 s after the front one: the middle leg touches down while the front toe
//! slides, and the impact is a jam.
//!
//! Independent routes: the contacts' velocities after it from the core's kinematics
//! (`contact_points`, the material point's `J q̇` at each site, not the constraint rows the
//! impact was solved with) — every kept contact at rest along its normal, every sticking one
//! at rest; the jammed toe's impulse, read from the rows of the mode the impact went into
//! (`impulse_mode`, every contact sticking; the mode after lets the other toe slide), pushes
//! and lies in its Coulomb cone, and the impulse is the momentum jump in those rows; the
//! kinetic energies the event records equal `½ q̇ᵀM̄q̇` evaluated again at its two
//! velocities, the later the smaller; and the leap flies on to its apex.
use nalgebra::DVector;
use rhex_model::leap::{leap_params, rotor_reflected_inertia, simulate_leap, LeapConfig};
use rhex_model::Rhex;
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::model::Friction;
use selfmanip_core::{contact_points, energy, Data, FlatGround};
use selfmanip_hybrid::EventKind;

#[test]
fn a_touchdown_that_leaves_a_toe_on_an_inconsistent_slide_jams_it() {
    let cfg = LeapConfig {
        strategy: "--".parse().unwrap(),
        t2_s: 0.1,
        ..LeapConfig::default()
    };
    let mut p = leap_params();
    p.leg_armature_kg_m2 = Some(rotor_reflected_inertia(&p, &cfg).unwrap());
    let r = simulate_leap(&p, &cfg).unwrap();
    assert!(r.flew, "{}", r.word_string());
    let exec = &r.execution;
    let e = exec
        .events
        .iter()
        .find(|e| e.kind == EventKind::Jam)
        .expect("the leap jams");
    // a touchdown: a contact active after it that was not before
    let touched: Vec<usize> = e
        .mode_after
        .active()
        .filter(|&k| !e.mode_before.contains(k))
        .collect();
    assert!(!touched.is_empty(), "{e:?}");
    // the jammed toe: sliding before, sticking after
    let k = *e
        .triggered
        .iter()
        .find(|&&k| {
            e.mode_before.kind(k) == Some(ContactKind::Slide)
                && e.mode_after.kind(k) == Some(ContactKind::Stick)
        })
        .expect("a sliding toe jammed into its stick");

    let mut params = p.clone();
    params.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(params).unwrap();
    let model = &rhex.model;
    assert!(model.joints.iter().all(|j| j.armature_kg_m2 > 0.0));
    let q = &e.q;
    let scale = e.qd_after.iter().fold(0.0f64, |m, v| m.max(v.abs())) + 1.0;
    let after = contact_points(model, &FlatGround, q, &e.qd_after).unwrap();
    for c in e.mode_after.active() {
        let v = after[c].velocity_m_s;
        let n = after[c].normal_into_ground;
        let vn = v[0] * n[0] + v[1] * n[1];
        assert!(vn.abs() < 1e-9 * scale, "contact {c} normal speed {vn}");
        if e.mode_after.kind(c) == Some(ContactKind::Stick) {
            let speed = v[0].hypot(v[1]);
            assert!(
                speed < 1e-9 * scale,
                "sticking contact {c} moves at {speed}"
            );
        }
    }
    // the jammed toe's impulse, in the rows of the mode the impact went into (U = −P_n pushes)
    let (mut p_t, mut p_n) = (0.0, 0.0);
    for (row, &v) in e.impulse_mode.rows().zip(&e.impulse) {
        if row.contact == k {
            match row.direction {
                RowDirection::Tangential => p_t = v,
                RowDirection::Normal => p_n = v,
            }
        }
    }
    let Friction::Sticking { mu } = model.contacts[k].friction else {
        panic!("a toe with friction")
    };
    assert!(-p_n > 0.0, "the jam's normal impulse pushes: {p_n}");
    assert!(
        p_t.abs() <= mu * -p_n * (1.0 + 1e-9),
        "|P_t| {p_t} against μ U(P_n) {}",
        mu * -p_n
    );
    assert!(p_t != 0.0, "a tangential impulse stops the slide");
    // the energies it records, evaluated again at its two velocities
    let seg = exec
        .segments
        .iter()
        .rev()
        .find(|s| (s.t1 - e.t).abs() <= 1e-12)
        .expect("the segment the jam ends");
    let mut y = vec![0.0; 2 * model.nq()];
    seg.eval(e.t, &mut y);
    let qd_before = &y[model.nq()..];
    // the impulse is in the rows of `impulse_mode` (every contact sticking in a jam), not
    // those of `mode_after`: its momentum jump `M̄ (q̇⁺ − q̇⁻) = −Aᵀ P` with `A` of that mode
    // (the impact's KKT system (5.10))
    assert_eq!(e.impulse.len(), e.impulse_mode.n_rows());
    momentum_jump_is_the_impulse(model, e, qd_before);
    let mut data = Data::new(model);
    let t_before = energy(model, &mut data, q, qd_before).unwrap().0;
    let t_after = energy(model, &mut data, q, &e.qd_after).unwrap().0;
    assert!((t_before - e.kinetic_before).abs() < 1e-9 * t_before);
    assert!((t_after - e.kinetic_after).abs() < 1e-9 * t_before);
    assert!(t_after < t_before);
    assert!(r.apex.is_some());
}

/// `M̄ (q̇⁺ − q̇⁻) + Aᵀ P = 0` at the event's configuration, `A` the constraint matrix of the
/// impact's mode `e.impulse_mode` (from the core's `Data::prepare`, not the reset's solve).
fn momentum_jump_is_the_impulse(
    model: &selfmanip_core::Model,
    e: &selfmanip_hybrid::Event,
    qd_before: &[f64],
) {
    let nq = model.nq();
    let mut data = Data::new(model);
    data.prepare_geometry(model, &FlatGround, e.impulse_mode, &e.q, qd_before)
        .unwrap();
    let dqd = DVector::from_iterator(nq, e.qd_after.iter().zip(qd_before).map(|(a, b)| a - b));
    let residual =
        &data.m_bar * dqd + data.constraints.a.transpose() * DVector::from_column_slice(&e.impulse);
    let scale = data.m_bar.norm() * qd_before.iter().fold(1.0f64, |m, v| m.max(v.abs()));
    assert!(residual.norm() < 1e-9 * scale, "M̄Δq̇ + AᵀP = {residual}");
}
