//! The impact's contact-set choice solves only the subsets its verdict needs
//! (`complementarity::Outcomes::accepted`): its answer must be the definition's, taken over
//! every subset (module docs of `crate::complementarity`): `J` is accepted when each of its
//! contacts pushes and each left-out contact `k` pulls in `J ∪ {k}` or cannot be held there.
//! Checked on landings of a body with four corners (sticking with finite and infinite `μ`,
//! sliding), whose answers include a unique set, no set and several sets, and on force events
//! (which solve every subset) of the same states.
mod systems;
use selfmanip_core::{ContactMode, FlatGround};
use selfmanip_hybrid::flow::FlowWorkspace;
use selfmanip_hybrid::reset_workspace::ResetWorkspace;
use selfmanip_hybrid::{ConstantTorque, HybridOptions, Termination, ZeroTorque};
use systems::{body, Friction, G};

/// [`ZeroTorque`] for as long as a reset stage may borrow it.
static UNFORCED: ConstantTorque = ZeroTorque;

/// The selection by the definition over every subset of `candidates` at `(q, q̇)`, as
/// `select` reports it: the unique set's mode and value, or the typed end.
fn by_definition(
    cx: &mut ResetWorkspace,
    candidates: &[usize],
    (q, qd): (&[f64], &[f64]),
    impact: bool,
) -> Result<(ContactMode, Vec<f64>), Termination> {
    let n = candidates.len();
    let outcomes: Vec<_> = (0u32..1 << n)
        .map(|bits| {
            let set: Vec<usize> = (0..n)
                .filter(|i| bits >> i & 1 == 1)
                .map(|i| candidates[i])
                .collect();
            cx.outcome(0.1, &set, ContactMode::FLIGHT, q, qd, impact)
                .unwrap()
        })
        .collect();
    let push = |o: &selfmanip_hybrid::impact::SetOutcome, k: usize| {
        o.push.iter().find(|p| p.0 == k).map_or(0.0, |p| p.1)
    };
    let accepted: Vec<_> = (0u32..1 << n)
        .filter(|&bits| {
            let Some(o) = &outcomes[bits as usize] else {
                return false;
            };
            o.push.iter().all(|&(_, u)| u >= -1e-12)
                && (0..n).filter(|i| bits >> i & 1 == 0).all(|i| {
                    outcomes[(bits | 1 << i) as usize]
                        .as_ref()
                        .is_none_or(|w| push(w, candidates[i]) < -1e-12)
                })
        })
        .map(|bits| outcomes[bits as usize].clone().unwrap())
        .collect();
    match &accepted[..] {
        [one] => Ok((one.mode, one.value.clone())),
        [] => Err(Termination::NoContactSolution { t: 0.1 }),
        _ => Err(Termination::SeveralContactSolutions {
            t: 0.1,
            candidates: accepted.iter().map(|a| a.mode).collect(),
        }),
    }
}

/// Landings of a tilted, spinning body on four corners at random velocities, and force
/// events at the same states: `select` agrees with the definition bit for bit, and the
/// landings meet each kind of answer.
#[test]
fn pruned_selection_is_the_definitions() {
    let model = body(
        2.0,
        0.03,
        G,
        &[
            ("a", -0.2, 0.05, Friction::Stick(Some(0.6))),
            ("b", 0.2, 0.05, Friction::Stick(None)),
            ("c", -0.1, 0.06, Friction::Slide),
            ("d", 0.1, 0.05, Friction::Coulomb(0.8)),
        ],
    );
    let mut ws = FlowWorkspace::new(&model);
    let mut cx = ResetWorkspace {
        model: &model,
        terrain: &FlatGround,
        ctrl: &UNFORCED,
        delta_t_s: 0.0,
        ws: &mut ws,
        barred: &[],
        fold_threshold: HybridOptions::default().fold_threshold,
        jammed: Vec::new(),
        held: Vec::new(),
    };
    // a fixed sequence of states (a linear congruential generator)
    let mut seed = 7u64;
    let mut uniform = |lo: f64, hi: f64| {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((seed >> 11) as f64 / (1u64 << 53) as f64)
    };
    let (mut unique, mut none, mut several) = (0, 0, 0);
    for case in 0..160 {
        let phi = if case % 4 == 0 {
            0.0
        } else {
            uniform(-0.3, 0.3)
        };
        let q = [0.0, -0.05, phi];
        let qd = [uniform(-1.0, 1.0), uniform(0.0, 2.0), uniform(-8.0, 8.0)];
        let candidates: Vec<usize> = (0..4).filter(|_| uniform(0.0, 1.0) < 0.8).collect();
        for impact in [true, false] {
            let expected = by_definition(&mut cx, &candidates, (&q, &qd), impact);
            let got = cx
                .select(0.1, &candidates, &[], ContactMode::FLIGHT, &q, &qd, impact)
                .unwrap()
                .map(|s| (s.mode, s.value));
            assert_eq!(got, expected, "case {case} impact {impact}");
            if impact {
                match got {
                    Ok(_) => unique += 1,
                    Err(Termination::NoContactSolution { .. }) => none += 1,
                    Err(_) => several += 1,
                }
            }
        }
    }
    assert!(unique > 0 && several > 0, "{unique} {none} {several}");
}
