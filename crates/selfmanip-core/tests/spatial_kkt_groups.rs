//! The range-space route packs consecutive rows of `A` whose deepest rates lie on one chain
//! into groups of at most three (`tree_kkt`'s module text): a point with friction is one
//! group of three, a frictionless point one of one. These contact sets make the other
//! groupings — two rows (a contact held in a plane), one group spanning three frictionless
//! contacts of one leg, rows ending in the root block (contacts on the trunk), and a run of
//! rows on one chain split after three — and the six-legged RHex's toes (groups of one row,
//! or of three with friction, each leg its own chain meeting the others at the root block),
//! and check `q̈`, `λ` against a second route: the full KKT matrix `[M Aᵀ; A 0]` solved
//! densely by LU.
mod spatial_support;
use nalgebra::{DMatrix, DVector, Vector3};
use selfmanip_core::spatial::rhex::RhexSixLegs;
use selfmanip_core::spatial::*;
use spatial_support::*;

/// `[q̈; −λ]` of the last constrained solve in `data`, from the dense KKT matrix.
fn dense_kkt(data: &SpatialData, tau: &DVector<f64>) -> (DVector<f64>, DVector<f64>) {
    let (nv, c) = (data.M.nrows(), data.A.nrows());
    let mut kkt = DMatrix::zeros(nv + c, nv + c);
    kkt.view_mut((0, 0), (nv, nv)).copy_from(&data.M);
    kkt.view_mut((nv, 0), (c, nv)).copy_from(&data.A);
    kkt.view_mut((0, nv), (nv, c))
        .copy_from(&data.A.transpose());
    let mut rhs = DVector::zeros(nv + c);
    rhs.rows_mut(0, nv).copy_from(&(tau - &data.h));
    rhs.rows_mut(nv, c).copy_from(&(-&data.A_drift));
    let x = kkt.lu().solve(&rhs).expect("a regular KKT matrix");
    (x.rows(0, nv).into_owned(), -x.rows(nv, c).into_owned())
}

/// The largest relative difference of `q̈`, `λ` between the range-space route and
/// [`dense_kkt`] over `n` random states of `model` standing on `contacts`.
fn worst_route_error(
    model: &SpatialModel,
    contacts: &[PointContact],
    rng: &mut rand_chacha::ChaCha8Rng,
    n: usize,
) -> f64 {
    let mut data = SpatialData::new(model);
    let rel = |a: &DVector<f64>, b: &DVector<f64>| (a - b).amax() / b.amax().max(1.0);
    let mut worst: f64 = 0.0;
    for _ in 0..n {
        let (q, v, tau) = random_state(model, rng);
        dynamics_at(model, &mut data, contacts, (&q, &v, &tau)).unwrap();
        assert_eq!(data.kkt_route, KktRoute::RangeSpace);
        let (qdd, lam) = dense_kkt(&data, &tau);
        worst = worst.max(rel(&data.qdd, &qdd)).max(rel(&data.lam, &lam));
    }
    worst
}

fn contact(model: &SpatialModel, frame: &str, friction: bool) -> PointContact {
    PointContact::new(model, frame, friction).unwrap()
}

#[test]
fn every_row_grouping_matches_the_dense_kkt_solve() {
    let model = quadruped();
    let contacts = vec![
        // three frictionless points of one leg: one group across three contacts
        contact(&model, "FL_foot", false),
        contact(&model, "FL_knee", false),
        contact(&model, "FL_thigh", false),
        // rows ending in the root block: a group of three, then one
        contact(&model, "trunk", false),
        contact(&model, "imu", true),
        // four rows on one chain: split after three
        contact(&model, "FR_foot", true),
        contact(&model, "FR_shin", false),
        // a point held in a plane: a group of two
        contact(&model, "HL_foot", true)
            .in_plane(Vector3::new(1.0, 0.3, 0.0))
            .unwrap(),
    ];
    let worst = worst_route_error(&model, &contacts, &mut rng(37), 20);
    assert!(worst < 1e-9, "routes differ by {worst:e}");
}

#[test]
fn one_row_groups_of_the_rhex_match_the_dense_kkt_solve() {
    let p = RhexSixLegs::table_4_2().with_table_4_2_legs();
    let model = p.model().unwrap();
    let legs = rhex_legs();
    // six frictionless toes (six groups of one row), then the first two with friction
    // (groups of three beside groups of one)
    let toes = |friction: usize| -> Vec<PointContact> {
        legs.iter()
            .enumerate()
            .map(|(i, leg)| p.toe(&model, leg, i < friction).unwrap())
            .collect()
    };
    let mut rng = rng(41);
    let worst = [toes(0), toes(2)]
        .iter()
        .map(|contacts| worst_route_error(&model, contacts, &mut rng, 10))
        .fold(0.0, f64::max);
    assert!(worst < 1e-9, "routes differ by {worst:e}");
}
