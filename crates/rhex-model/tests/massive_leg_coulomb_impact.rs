//! Issue 16 (task r19): with Table 4.2's leg mass (`m_l = 0.126`, the legs' rotors as
//! armature) these leaps ended `singular_contact` at a touchdown: a leg touching down while
//! the other held (the front toe alone, or the rear toe sliding), the engine's impact law
//! (5.10) with Assumption 5.9 left the holder on a slide with no consistent continuation
//! (Painlevé), and its stick jam pulled or left its cone. The plastic impact with Coulomb
//! friction at every contact (`selfmanip_hybrid::coulomb_impact`) resolves them; they now
//! fly to an apex.
//!
//! Checked at each such event (a `jam` in the leap's events), by routes outside the
//! engine's resets, from the core's kinematics at `(q, q̇⁺)`: every contact held after it
//! has zero normal velocity (the gap's rate by central differences of the core's contact
//! geometry along `q ± h q̇⁺`), a sticking one a toe at rest (its material velocity), every
//! contact let go is not approaching the ground; the kinetic energy does not grow; and over
//! the whole leap the energy balances, `E₁ − E₀ = W + W_fr − L` (integrated powers against
//! state energies). No apex numbers are asserted.
mod common;
use common::events_of;
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LegActuator, X_RHEX_LEG};
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::contact::{contact_geometry, ContactKind};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::FlatGround;
use selfmanip_hybrid::EventKind;

/// The 41-point sweeps' massive legs (`python: sweep(…, m_l=0.126)`).
fn massive() -> RhexParams {
    let mut p = leap_params();
    p.m_l = 0.126;
    p
}

fn check(strategy: &str, t2_s: f64, actuator: LegActuator) {
    let p = massive();
    let cfg = LeapConfig {
        strategy: strategy.parse().unwrap(),
        t2_s,
        actuator,
        ..LeapConfig::default()
    };
    let r = simulate_leap(&p, &cfg).unwrap();
    let word = r.word_string();
    let ctx = format!(
        "{strategy} t2 = {t2_s}: {word} {:?}",
        r.execution.termination
    );
    assert!(r.flew, "{ctx}");
    assert!(r.apex.is_some(), "{ctx}");
    let mut pp = p.clone();
    pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(pp).unwrap();
    let model = &rhex.model;
    let nq = model.nq();
    let terrain = FlatGround;
    let mut kin = Kinematics::default();
    let jams = events_of(&r.execution, EventKind::Jam);
    assert!(!jams.is_empty(), "no jam: {ctx}");
    for e in jams {
        let (q, qd) = (&e.q[..], &e.qd_after[..]);
        assert!(e.kinetic_after <= e.kinetic_before + 1e-9, "{ctx}: {e:?}");
        let mut gap = |s: f64, c: usize| {
            let qs: Vec<f64> = (0..nq).map(|i| q[i] + s * qd[i]).collect();
            kin.compute(model, &qs, &vec![0.0; nq]);
            contact_geometry(model, &kin, &terrain, c).gap_m
        };
        let h = 1e-7;
        let candidates: Vec<usize> = e
            .mode_before
            .active()
            .chain(e.triggered.iter().copied())
            .collect();
        for &c in &candidates {
            // the gap's rate along q̇⁺ (positive: leaving the ground)
            let rate = (gap(h, c) - gap(-h, c)) / (2.0 * h);
            match e.mode_after.kind(c) {
                Some(kind) => {
                    assert!(
                        gap(0.0, c).abs() < 1e-6,
                        "{ctx}: contact {c} off the ground"
                    );
                    assert!(
                        rate.abs() < 1e-5,
                        "{ctx}: held contact {c} moves off at {rate}"
                    );
                    if kind == ContactKind::Stick {
                        let mut kv = Kinematics::default();
                        kv.compute(model, q, qd);
                        let g = contact_geometry(model, &kv, &terrain, c);
                        let v = kv.material_velocity(g.part, g.point);
                        assert!(
                            v.norm() < 1e-5,
                            "{ctx}: sticking contact {c} moves at {v:?}"
                        );
                    }
                }
                None => assert!(
                    rate > -1e-5,
                    "{ctx}: contact {c} let go approaches at {rate}"
                ),
            }
        }
    }
    let rep = r.energy_report().unwrap();
    let scale = rep.joint_work_j.abs() + rep.final_j.abs() + 1.0;
    assert!(rep.residual_j().abs() < 1e-6 * scale, "{ctx}: {rep:?}");
    assert!(rep.impact_loss_j >= -1e-9, "{ctx}: {rep:?}");
}

/// The (−,+) leaps of the geared sweep at t2 = 0.08–0.10 s (the rear toe touching down
/// while the front toe holds alone, `0100`).
#[test]
fn rear_leg_touching_down_while_the_front_toe_holds_alone_flies() {
    for t2 in [0.08, 0.09, 0.10] {
        check("-+", t2, X_RHEX_LEG.actuator());
    }
}

/// The (+,−) geared leap at t2 = −0.03 s (the front toe touching down while the rear toe
/// slides, `100s`) and chapter 3's saturated-torque legs at (+,+) −0.01 and (−,+) 0.06.
#[test]
fn front_leg_touching_down_while_the_rear_toe_slides_flies() {
    check("+-", -0.03, X_RHEX_LEG.actuator());
    check("++", -0.01, LegActuator::SaturatedTorque);
    check("-+", 0.06, LegActuator::SaturatedTorque);
}
