//! `Data::prepare` split into its state stages (once per state) and its mode stages (once per
//! mode), as the resets' enumeration of contact sets uses it: every mode prepared on a
//! workspace that other modes at the same state went through solves as on a fresh workspace
//! prepared at once, and a singular mode fails with the kind that `prepare` reports.
mod common;
use common::*;
use selfmanip::core::{
    forward_dynamics_prepared, ContactMode, CoreError, Data, FlatGround, Model, SingularityKind,
};
use selfmanip::rhex::LegShape;

/// `(q̈, λ)` of `mode` at the prepared state with torques `tau` (exact bits), or why not: the
/// KKT matrix's singularity kind, or the solve's error.
type Solved = Result<(Vec<u64>, Vec<u64>), String>;

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

fn solve(model: &Model, d: &mut Data, tau: &[f64]) -> Solved {
    forward_dynamics_prepared(model, d, tau, None).map_err(|e| e.to_string())?;
    Ok((bits(d.qdd.as_slice()), bits(d.lambda.as_slice())))
}

/// Every contact set of `model` (kinds: each contact's default, then all sliding), at
/// `(q, q̇)`: on a fresh workspace with `prepare`, and on one workspace whose state stages
/// were prepared once, mode after mode.
fn compare_routes(model: &Model, q: &[f64], qd: &[f64], tau: &[f64]) -> usize {
    let n = model.n_contacts();
    let mut shared = Data::new(model);
    shared.prepare_state(model, q, qd).unwrap();
    let mut singular = 0;
    for bits_set in 0u32..(1 << n) {
        let set: Vec<usize> = (0..n).filter(|i| bits_set >> i & 1 == 1).collect();
        let base = ContactMode::with_defaults(model, &set).unwrap();
        let sliding = set.iter().fold(base, |m, &k| {
            m.with(k, selfmanip::core::contact::ContactKind::Slide)
        });
        for mode in [base, sliding] {
            let mut fresh = Data::new(model);
            let want: Solved = match fresh.prepare(model, &FlatGround, mode, q, qd) {
                Ok(()) => solve(model, &mut fresh, tau),
                Err(CoreError::SingularKkt { kind, .. }) => {
                    singular += 1;
                    Err(format!("{kind:?}"))
                }
                Err(e) => panic!("{e}"),
            };
            let got: Solved = match shared.prepare_mode(model, &FlatGround, mode, qd).unwrap() {
                Ok(()) => solve(model, &mut shared, tau),
                Err(kind) => Err(format!("{kind:?}")),
            };
            assert_eq!(got, want, "mode {mode:?}");
        }
    }
    singular
}

#[test]
fn modes_prepared_on_a_shared_state_solve_as_on_a_fresh_workspace() {
    // massless legs: sets that leave a leg's shin unpinned or over-constrain the body are
    // singular, the others regular
    let rhex = rhex_massless(LegShape::HalfCircle);
    let q = [0.1, 0.1, 0.0, -0.17, 0.0];
    let qd = [3.0, -2.0, 0.4, 0.2, -1.5];
    let singular = compare_routes(&rhex.model, &q, &qd, &[0.5, -0.3]);
    // singular and regular modes are both among them
    assert!(singular > 0 && singular < 2 << rhex.model.n_contacts());
    let rhex = rhex_massive(LegShape::HalfCircle);
    compare_routes(&rhex.model, &q, &qd, &[0.5, -0.3]);
}

#[test]
fn prepare_mode_reports_the_singularity_kind_of_prepare() {
    let rhex = rhex_massless(LegShape::HalfCircle);
    let m = &rhex.model;
    let q = [0.1, 0.1, 0.0, -0.17, 0.0];
    let mut d = Data::new(m);
    d.prepare_state(m, &q, &[0.0; 5]).unwrap();
    // c = 6 > q = 5
    let over = rhex.mode("1111").unwrap();
    assert_eq!(
        d.prepare_mode(m, &FlatGround, over, &[0.0; 5]).unwrap(),
        Err(SingularityKind::RedundantConstraints)
    );
    let leg = data_robot("robots/massless_two_link_leg.toml");
    let mut d = Data::new(&leg);
    let q = [0.3, -0.6, 0.0, -0.3, 0.0];
    d.prepare_state(&leg, &q, &[0.0; 5]).unwrap();
    let foot = ContactMode::parse_names(&leg, "foot").unwrap();
    assert_eq!(
        d.prepare_mode(&leg, &FlatGround, foot, &[0.0; 5]).unwrap(),
        Err(SingularityKind::UnconstrainedMasslessMotion)
    );
}
