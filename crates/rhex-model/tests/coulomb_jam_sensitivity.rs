//! Derivatives of whole leaps through a Coulomb impact: RHex leaps with Table 4.2's leg mass
//! (`m_l = 0.126`) whose second toe's touchdown, with the first toe holding, is resolved by
//! the plastic impact with Coulomb friction at every contact (a `jam`,
//! `selfmanip_hybrid::coulomb_impact`; `tests/massive_leg_coulomb_impact.rs`). Its reset is
//! differentiated on its active set (`coulomb_impact_jacobian`), so the jam's saltation is
//! `Defined` and the leap's derivatives are returned.
//!
//! Checked against Richardson-extrapolated central differences of whole leaps (the
//! independent route), each to 1e-5 relative to the difference's size plus 1e-3: every
//! event's time and the apex (the end state; its `ż`, 0 by definition, left out), along a
//! start-state direction (the rear leg's rate) and in the body's mass and the toes' `μ`.
//! That the jam's impulse is a Coulomb impact's is checked from the event alone: a contact
//! it leaves sliding took an impulse on its cone's edge, `|P_t| = μ |P_n|`.
mod common;
use common::tight;
use nalgebra::DMatrix;
use rhex_model::leap::{leap_params, LeapConfig};
use rhex_model::leap_sensitivity::{leap_with_sensitivity_from, LeapSensitivity};
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::contact::{ContactKind, RowDirection};
use selfmanip_core::model::Friction;
use selfmanip_hybrid::sensitivity::SaltationStatus;
use selfmanip_hybrid::EventKind;

/// The apex's `ż` column: 0 at the apex by definition, not compared.
const ZDOT: usize = 5;

fn massive() -> RhexParams {
    let mut p = leap_params();
    p.m_l = 0.126;
    p
}

/// A parameter moved by `s`: the body's mass or a toe pair's `μ`.
fn moved(name: &str, s: f64) -> RhexParams {
    let mut p = massive();
    match name {
        "m_b" => p.m_b += s,
        "mu_front" => p.mu_front = p.mu_front.map(|m| m + s),
        "mu_rear" => p.mu_rear = p.mu_rear.map(|m| m + s),
        _ => unreachable!("{name}"),
    }
    p
}

/// `(event times, apex)` of a leap, with the word it took.
fn run(p: &RhexParams, cfg: &LeapConfig, offset: Option<&[f64]>) -> (String, Vec<f64>, [f64; 7]) {
    let r = leap_with_sensitivity_from(p, cfg, &[], offset, None).unwrap();
    let times = r.result.execution.events.iter().map(|e| e.t).collect();
    (
        r.result.word_string(),
        times,
        r.result.apex.unwrap().to_array(),
    )
}

/// Richardson-extrapolated central differences of the event times and the apex along `f(s)`
/// (a leap at `s`), which must take the nominal word on every side.
fn richardson(
    word: &str,
    h: f64,
    f: impl Fn(f64) -> (String, Vec<f64>, [f64; 7]),
) -> (Vec<f64>, [f64; 7]) {
    let d = |h: f64| {
        let (a, b) = (f(h), f(-h));
        assert_eq!(
            (&a.0[..], &b.0[..]),
            (word, word),
            "the word moves within {h}"
        );
        let times: Vec<f64> =
            a.1.iter()
                .zip(&b.1)
                .map(|(x, y)| (x - y) / (2.0 * h))
                .collect();
        let apex: [f64; 7] = std::array::from_fn(|c| (a.2[c] - b.2[c]) / (2.0 * h));
        (times, apex)
    };
    let (d1, d2) = (d(h), d(0.5 * h));
    (
        d1.0.iter()
            .zip(&d2.0)
            .map(|(x, y)| (4.0 * y - x) / 3.0)
            .collect(),
        std::array::from_fn(|c| (4.0 * d2.1[c] - d1.1[c]) / 3.0),
    )
}

/// The jam's impulse is a Coulomb impact's: a contact it leaves sliding took an impulse on
/// its cone's edge; and its saltation is defined.
fn assert_coulomb_jam(p: &RhexParams, cfg: &LeapConfig, sens: &LeapSensitivity) {
    let mut pp = p.clone();
    pp.pairs = cfg.strategy.chapter3_pairs().to_vec();
    let rhex = Rhex::new(pp).unwrap();
    let events = &sens.result.execution.events;
    let i = events
        .iter()
        .position(|e| e.kind == EventKind::Jam)
        .expect("a jam");
    assert_eq!(sens.events[i].status, SaltationStatus::Defined);
    let e = &events[i];
    let on_edge = e.mode_after.active().any(|k| {
        let Friction::Sticking { mu } = rhex.model.contacts[k].friction else {
            return false;
        };
        let pick = |d: RowDirection| {
            e.impulse_mode
                .rows()
                .zip(&e.impulse)
                .find(|(r, _)| r.contact == k && r.direction == d)
                .map(|(_, v)| *v)
        };
        let (Some(pt), Some(pn)) = (pick(RowDirection::Tangential), pick(RowDirection::Normal))
        else {
            return false;
        };
        e.mode_after.kind(k) == Some(ContactKind::Slide)
            && pn.abs() > 1e-6
            && (pt.abs() - mu * pn.abs()).abs() <= 1e-9 * pn.abs()
    });
    assert!(on_edge, "{e:?}");
}

fn check(strategy: &str, t2: f64, names: &[&str]) {
    let p = massive();
    let cfg = tight(strategy, t2);
    let nq = 5;
    // the rear leg's rate at the start (q = [θ_front, θ_rear, x, z, φ])
    let mut dir = DMatrix::zeros(2 * nq, 1);
    dir[(nq + 1, 0)] = 1.0;
    let sens = leap_with_sensitivity_from(&p, &cfg, names, None, Some(&dir)).unwrap();
    assert!(sens.ok, "{:?}", sens.reason);
    assert_coulomb_jam(&p, &cfg, &sens);
    let word = sens.result.word_string();
    let mut worst: f64 = 0.0;
    let mut compare = |what: &str, col: usize, (times, apex): (Vec<f64>, [f64; 7])| {
        for (i, fd) in times.iter().enumerate() {
            let exact = sens.event_times[i].as_ref().expect("every time defined")[col];
            let e = (exact - fd).abs() / (fd.abs() + 1e-3);
            worst = worst.max(e);
            assert!(
                e < 1e-5,
                "{strategy} {t2} {what}: d t_{i} {exact:e} vs {fd:e}"
            );
        }
        for (c, fd) in apex.iter().enumerate().filter(|(c, _)| *c != ZDOT) {
            // column 0 the start direction, then the parameters
            let exact = match col {
                0 => sens.d_apex_d_start[c][0],
                _ => sens.d_apex[c][col - 1],
            };
            let e = (exact - fd).abs() / (fd.abs() + 1e-3);
            worst = worst.max(e);
            assert!(
                e < 1e-5,
                "{strategy} {t2} {what}: d apex[{c}] {exact:e} vs {fd:e}"
            );
        }
    };
    let start = richardson(&word, 1e-4, |s| {
        let mut off = vec![0.0; 2 * nq];
        off[nq + 1] = s;
        run(&p, &cfg, Some(&off))
    });
    compare("rear leg rate", 0, start);
    for (k, name) in names.iter().enumerate() {
        let fd = richardson(&word, 1e-4, |s| run(&moved(name, s), &cfg, None));
        assert!(
            fd.1.iter().any(|v| v.abs() > 1e-3),
            "{strategy}: the apex does not move with {name}"
        );
        compare(name, 1 + k, fd);
    }
    eprintln!("{strategy} {t2}: worst {worst:.1e}");
}

/// (−,+) at t2 = 0.08 s: the rear toe touches down while the front toe holds alone; the
/// Coulomb impact leaves it slipping and lets the front toe go.
#[test]
fn rear_toe_landing_on_a_coulomb_impact_matches_central_differences() {
    check("-+", 0.08, &["m_b", "mu_rear"]);
}

/// (+,−) at t2 = −0.03 s: the front toe touches down while the rear toe slides; both slip
/// through the impact.
#[test]
fn front_toe_landing_on_a_coulomb_impact_matches_central_differences() {
    check("+-", -0.03, &["m_b", "mu_front", "mu_rear"]);
}
