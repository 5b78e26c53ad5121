//! The two factorizations of the spatial KKT system agree: where `M` is positive definite the
//! engine takes the range-space route (the tree's sparse `LᵀDL`, `A M⁻¹ Aᵀ`), and the
//! null-space block inverse of the planar core (`selfmanip_core::kkt`), factored here on the
//! same `M`, `A` and right-hand side, is the second route; a singular `M` takes the null-space
//! route.
mod spatial_support;
use nalgebra::DVector;
use selfmanip_core::kkt::KktFactorization;
use selfmanip_core::spatial::*;
use spatial_support::*;

/// `[M Aᵀ; A 0][x; y] = [f; g]` by the null-space block inverse on `data`'s `M` and `A`.
fn null_space_solve(
    data: &SpatialData,
    f: &DVector<f64>,
    g: &DVector<f64>,
) -> (DVector<f64>, DVector<f64>) {
    let mut kkt = KktFactorization::default();
    kkt.factor(&data.M, &data.A).unwrap();
    let mut x = DVector::zeros(f.len());
    let mut y = DVector::zeros(g.len());
    kkt.solve(
        f.as_slice(),
        g.as_slice(),
        x.as_mut_slice(),
        y.as_mut_slice(),
    );
    (x, y)
}

fn rel(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1.0)
}

#[test]
fn range_space_route_matches_the_block_inverse() {
    let (model, mut data, mut rng) = setup(quadruped(), 29);
    let mut worst: f64 = 0.0;
    for friction in [[true; 4], [true, false, true, false], [false; 4]] {
        let contacts = feet(&model, friction);
        for _ in 0..20 {
            let (q, v, tau) = random_state(&model, &mut rng);
            dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
            assert_eq!(data.kkt_route, KktRoute::RangeSpace);
            let (qdd, y) = null_space_solve(&data, &(&tau - &data.h), &(-&data.A_drift));
            worst = worst.max(rel(&data.qdd, &qdd)).max(rel(&data.lam, &(-y)));

            let imp = impact(&model, &mut data, &contacts, q.as_slice(), v.as_slice()).unwrap();
            assert_eq!(data.kkt_route, KktRoute::RangeSpace);
            let (dv, y) = null_space_solve(&data, &DVector::zeros(model.nv), &(-&data.A * &v));
            worst = worst
                .max(rel(&imp.v_plus, &(&v + dv)))
                .max(rel(&imp.impulse, &(-y)));
        }
    }
    assert!(worst < 1e-11, "routes differ by {worst:e}");
}

/// A fixed base has no root block: the range-space route factors the legs' chains alone and
/// still agrees with the block inverse.
#[test]
fn range_space_route_on_a_fixed_base_matches_the_block_inverse() {
    let (model, mut data, mut rng) = setup(
        SpatialModel::from_urdf_file(QUADRUPED, BaseKind::Fixed, None).unwrap(),
        31,
    );
    let mut worst: f64 = 0.0;
    for friction in [[true, false, true, false], [false; 4]] {
        let contacts = feet(&model, friction);
        for _ in 0..20 {
            let q = random_vector(model.nq, 1.0, &mut rng);
            let (v, tau) = (
                random_vector(model.nv, 2.0, &mut rng),
                random_vector(model.nv, 5.0, &mut rng),
            );
            dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
            assert_eq!(data.kkt_route, KktRoute::RangeSpace);
            let (qdd, y) = null_space_solve(&data, &(&tau - &data.h), &(-&data.A_drift));
            worst = worst.max(rel(&data.qdd, &qdd)).max(rel(&data.lam, &(-y)));
        }
    }
    assert!(worst < 1e-11, "routes differ by {worst:e}");
}

#[test]
fn singular_mass_matrix_takes_the_null_space_route() {
    let (model, mut data, mut rng) = setup(quadruped_massless_shins(), 31);
    let contacts = feet(&model, [true; 4]);
    let (q, v, tau) = random_state(&model, &mut rng);
    dynamics_at(&model, &mut data, &contacts, (&q, &v, &tau)).unwrap();
    assert_eq!(data.kkt_route, KktRoute::NullSpace);
    let (acc, eom) = dynamics_residuals(&data, &tau);
    assert!(acc < 1e-10 && eom < 1e-10, "{acc:e} {eom:e}");
}
