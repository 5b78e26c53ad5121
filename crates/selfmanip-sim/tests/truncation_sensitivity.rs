//! Derivatives of a whole run through a Zeno truncation and its dwell's end
//! (`selfmanip_hybrid::sensitivity`, docs/sensitivity.md "A Zeno truncation") against an
//! independent route: central differences of whole runs, each perturbed run keeping the
//! reference's event word (kind, contacts, modes of every event).
//!
//! The robot is `retouch_chatter.rs`'s: a 9.5 kg body on two legs of two massive links under
//! stiff servos, dropped 1 cm pitched nose-down; the front foot lands and sticks, the hind
//! foot re-touches again and again (its impact keeps it, its servo's damping lifts it) until
//! the chatter criterion truncates it — the re-touch and the truncation's plastic impact into
//! the held mode at one instant — and the hold ends `dwell_s` later by its length, force
//! complementarity judging the held foot. Checked, at a final time inside the dwell and
//! one after its end:
//! - the state Jacobian `dx(T)/dx(0)` (columns of the body's height, pitch and a knee, and
//!   their rates) against central differences of the initial state;
//! - the column of a behaviour parameter (the hind knee servo's stiffness `kp`) against
//!   central differences of the parameter.
use nalgebra::DMatrix;
use selfmanip_hybrid::sensitivity::{execution_sensitivity_columns, Parameter};
use selfmanip_hybrid::{EventKind, Execution};
use selfmanip_sim::periodic::run_sensitivity;
use selfmanip_sim::{Run, Scenario, Simulation};
mod common;

const Q0: [f64; 7] = [0.46, -0.7254, 0.46, -0.7254, 0.0, -0.3205, -0.05];
const KP: f64 = 385.65;

/// The robot (its hind knee's stiffness the parameter `kp`) from `(q0, qd0)` to `t_final`.
fn scenario(q0: &[f64], qd0: &[f64], kp: f64, t_final: f64) -> Scenario {
    let mut s = common::retouch_robot("kp".into());
    s["behaviour"]["parameters"] = serde_json::json!({ "kp": kp });
    s["initial"] = serde_json::json!({"q": q0, "qd": qd0});
    // every component to the same absolute tolerance: a difference of whole runs resolves
    // a derivative no better than each run's error
    s["options"] = serde_json::json!({"t_final_s": t_final, "rtol": 1e-11,
        "velocity_tolerance": "uniform"});
    Scenario::from_json_str(&s.to_string()).unwrap()
}

/// The run to `t_final`, with the unresolved-flight rule on or off
/// (`HybridOptions::truncate_unresolved_flights`).
fn run(q0: &[f64], qd0: &[f64], kp: f64, (t_final, unresolved): (f64, bool)) -> Run {
    let mut sim = Simulation::new(&scenario(q0, qd0, kp, t_final)).unwrap();
    sim.options.truncate_unresolved_flights = unresolved;
    sim.run().unwrap()
}

/// A column's name, its exact value and central differences at steps `h` and `2h`.
type Check = (String, Vec<f64>, Vec<f64>, Vec<f64>);

/// The event word of a run: kind, contacts and modes of every event.
fn word(e: &Execution) -> Vec<String> {
    e.events
        .iter()
        .map(|e| {
            format!(
                "{:?} {:?} {:?} {:?}",
                e.kind, e.triggered, e.mode_before, e.mode_after
            )
        })
        .collect()
}

fn end_state(e: &Execution) -> Vec<f64> {
    e.q.iter().chain(&e.qd).copied().collect()
}

/// Central difference of the end state at `T` along `f(h)`, the run keeping `w`.
fn central(w: &[String], h: f64, f: &dyn Fn(f64) -> Run) -> Vec<f64> {
    let (a, b) = (f(h), f(-h));
    assert_eq!(word(&a.execution), w, "+h: another event word");
    assert_eq!(word(&b.execution), w, "-h: another event word");
    let (xa, xb) = (end_state(&a.execution), end_state(&b.execution));
    xa.iter()
        .zip(&xb)
        .map(|(p, m)| (p - m) / (2.0 * h))
        .collect()
}

/// `|a − b|∞ / (|b|∞ + floor)`.
fn rel(a: &[f64], b: &[f64], floor: f64) -> f64 {
    let scale = b.iter().fold(0.0f64, |m, x| m.max(x.abs())) + floor;
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
        / scale
}

#[test]
fn through_a_chatter_truncation() {
    check(false);
}

#[test]
fn through_an_unresolved_flight_truncation() {
    check(true);
}

fn check(unresolved: bool) {
    // falling at 0.1 m/s (NED: z down), so that no apex starts the run
    let qd0 = [0.0, 0.0, 0.0, 0.0, 0.0, 0.1, 0.0];
    let probe = run(&Q0, &qd0, KP, (0.2, unresolved));
    let ex = &probe.execution;
    // taken at once after the re-touch that filled the criterion, at its instant
    let pair = ex.events.windows(2);
    let (before, tz) = pair
        .map(|w| (&w[0], &w[1]))
        .find(|(_, z)| z.kind == EventKind::ZenoTruncation)
        .map(|(b, z)| (b, z.t))
        .expect("the re-touch chatter is truncated");
    assert!(
        before.kind == EventKind::Touchdown && before.t == tz,
        "{before:?}"
    );
    // the dwell ends by its length, force complementarity letting the held foot go there
    let end = *ex
        .dwell_ends
        .iter()
        .find(|&&t| t > tz)
        .expect("the dwell ends by its length");
    let released = ex
        .events
        .iter()
        .find(|e| e.t == end)
        .expect("an event at the dwell's end");
    assert!(released.mode_after != released.mode_before, "{released:?}");
    // a final time inside the dwell, and one after its end
    for t_final in [0.5 * (tz + end), end + 0.5 * (end - tz)] {
        let r0 = run(&Q0, &qd0, KP, (t_final, unresolved));
        let w = word(&r0.execution);
        let n2 = 2 * r0.model.nq();
        let s = run_sensitivity(&r0).unwrap();
        let jac = s.state_jacobian.expect("defined through the truncation");
        let cs = execution_sensitivity_columns(
            &r0.model,
            &r0.terrain,
            &r0.execution,
            &DMatrix::zeros(n2, 0),
            &[Parameter::Controller("kp".into())],
        )
        .unwrap();
        let cols = cs.columns.expect("defined through the truncation");
        // the body's height and pitch and their rates (the knee's own columns decay within
        // microseconds under its servo: differences of whole runs do not resolve them)
        let mut checks: Vec<Check> = Vec::new();
        for i in [5, 6, 7 + 5, 7 + 6] {
            let fd_at = |h: f64| {
                central(&w, h, &|h| {
                    let (mut q, mut qd) = (Q0, qd0);
                    if i < 7 {
                        q[i] += h;
                    } else {
                        qd[i - 7] += h;
                    }
                    run(&q, &qd, KP, (t_final, unresolved))
                })
            };
            let col = jac.column(i).iter().copied().collect();
            checks.push((format!("dx/dx0[{i}]"), col, fd_at(1e-5), fd_at(2e-5)));
        }
        let fd_kp = |h: f64| central(&w, h, &|h| run(&Q0, &qd0, KP + h, (t_final, unresolved)));
        let col = cols.column(0).iter().copied().collect();
        checks.push(("dx/dkp".into(), col, fd_kp(1e-2), fd_kp(2e-2)));
        for (name, exact, fd, fd2) in checks {
            // the differences have converged in h: two steps agree
            let gap = rel(&fd2, &fd, 1e-3);
            let err = rel(&exact, &fd, 1e-3);
            eprintln!("T {t_final}: {name} error {err:.2e} (|D(h) - D(2h)| {gap:.2e})");
            assert!(gap < 1e-3, "{name}: the differences have not converged");
            assert!(err < 1e-3, "T {t_final}: {name} {exact:?} vs {fd:?}");
        }
    }
}
