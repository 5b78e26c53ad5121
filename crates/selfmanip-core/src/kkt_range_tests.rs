//! The range-space route of [`super`] against the null-space route and a dense LU of the KKT
//! matrix, on the systems of planar robots: the robots of `tests/data/robots` and random
//! legged trees of 7 to 13 coordinates (link masses random, some tiny, some zero), at random
//! states, in every contact mode of their first four contacts.
use super::*;
use crate::{
    forward_dynamics, ContactKind, ContactMode, Data, FlatGround, Model, RobotDescription,
};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The null-space route's factorization of `(M̄, A)`, whatever the size.
fn null_route(
    mbar: &DMatrix<f64>,
    a: &DMatrix<f64>,
) -> std::result::Result<KktFactorization, SingularityKind> {
    let mut k = KktFactorization::default();
    k.load(mbar, a, None);
    with_dims!(k.m, k.c, |md, cd| factor_kernel(md, cd, &mut k, false))?;
    Ok(k)
}

/// `‖u − v‖ / ‖v‖` (`‖u − v‖` for `v = 0`).
fn rel(u: &[f64], v: &[f64]) -> f64 {
    rel_above(u, v, 0.0)
}

/// `‖u − v‖ / max(‖v‖, floor)` (`‖u − v‖` where both are zero): [`rel`] against a size `v`
/// may fall below by cancellation.
fn rel_above(u: &[f64], v: &[f64], floor: f64) -> f64 {
    let d = u
        .iter()
        .zip(v)
        .map(|(a, b)| (a - b).powi(2))
        .sum::<f64>()
        .sqrt();
    let n = v.iter().map(|b| b * b).sum::<f64>().sqrt().max(floor);
    if n > 0.0 {
        d / n
    } else {
        d
    }
}

/// A random planar legged tree of `m` coordinates: a body and legs of one to three links
/// (at least two legs), each with a sticking point toe at its end. A link is massless with
/// probability 1/10, of a tiny mass (1e-9 to 1e-4 kg) with probability 1/10, else of
/// 0.05 to 2 kg.
fn random_tree(m: usize, r: &mut ChaCha8Rng) -> Model {
    let mut joints = m - 3;
    let mut legs = vec![];
    while joints > 0 {
        let n = r.gen_range(1..=3.min(joints));
        // keep at least two legs
        let n = if legs.is_empty() && n == joints && joints > 1 {
            joints - 1
        } else {
            n
        };
        legs.push(n);
        joints -= n;
    }
    let mut text = format!(
        "name = \"tree\"\ngravity_m_s2 = 9.81\n[body]\nmass_kg = {}\ninertia_kg_m2 = {}\n",
        r.gen_range(1.0..10.0),
        r.gen_range(0.01..0.2)
    );
    let mut toes = String::new();
    for (i, &n) in legs.iter().enumerate() {
        text += &format!(
            "[[legs]]\nname = \"leg{i}\"\nhip_m = [{}, 0.0]\n",
            r.gen_range(-0.3..0.3)
        );
        let mut length = 0.0;
        for _ in 0..n {
            length = r.gen_range(0.1..0.3);
            text += &format!("[[legs.links]]\nlength_m = {length}\n");
            let mass = match r.gen_range(0..10) {
                0 => None,
                1 => Some(10f64.powf(r.gen_range(-9.0..-4.0))),
                _ => Some(r.gen_range(0.05..2.0)),
            };
            if let Some(mass) = mass {
                let inertia = mass * length * length * r.gen_range(0.02..0.2);
                text += &format!("mass_kg = {mass}\ninertia_kg_m2 = {inertia}\n");
            }
        }
        toes += &format!(
            "[[contacts]]\nname = \"toe{i}\"\nleg = \"leg{i}\"\n\
             shape = {{ kind = \"point\", position_m = [0.0, {length}] }}\n\
             friction = {{ kind = \"sticking\", mu = 0.8 }}\n"
        );
    }
    RobotDescription::from_toml_str(&(text + &toes))
        .unwrap()
        .build()
        .unwrap()
}

/// The robots of the workspace's `tests/data/robots`.
fn data_robots() -> Vec<(String, Model)> {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/robots");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    files.sort();
    files
        .into_iter()
        .map(|p| {
            let model = RobotDescription::from_file(&p).unwrap().build().unwrap();
            (p.display().to_string(), model)
        })
        .collect()
}

/// Every mode of the first four contacts (each off, sticking or sliding).
fn modes(model: &Model) -> Vec<ContactMode> {
    let n = model.contacts.len().min(4);
    let mut out = vec![];
    for code in 0..3usize.pow(n as u32) {
        let mut mode = ContactMode::FLIGHT;
        let mut k = code;
        for contact in 0..n {
            match k % 3 {
                1 => mode = mode.with(contact, ContactKind::Stick),
                2 => mode = mode.with(contact, ContactKind::Slide),
                _ => {}
            }
            k /= 3;
        }
        out.push(mode);
    }
    out
}

/// What one system showed: whether the range-space route was taken, and its largest
/// relative difference from the null-space route and from a dense LU.
#[derive(Default)]
struct Tally {
    systems: usize,
    range: usize,
    /// Of these, the systems the massless range-space route solved.
    massless: usize,
    worst: f64,
    /// Forward dynamics compared on both routes.
    dynamics: usize,
}

/// At `n_states` random states of `model`, in every mode of [`modes`]: where
/// [`KktFactorization`] takes the range-space route, its solution of the KKT system for the
/// dynamics' right-hand side (`f` the generalized force of random torques, `g` random) and
/// its blocks agree with the null-space route's and a dense LU's to a relative 1e-10; its
/// null-space basis and diagnostics are the null-space route's bit for bit; and the
/// null-space route is not singular there.
fn check_robot(model: &Model, n_states: usize, r: &mut ChaCha8Rng, tally: &mut Tally) {
    let nq = model.nq();
    let mut data = Data::new(model);
    for _ in 0..n_states {
        let q: Vec<f64> = (0..nq)
            .map(|i| {
                if i < model.n_joints() {
                    r.gen_range(-1.5..1.5)
                } else {
                    r.gen_range(-0.5..0.5)
                }
            })
            .collect();
        let qd: Vec<f64> = (0..nq).map(|_| r.gen_range(-2.0..2.0)).collect();
        let tau: Vec<f64> = (0..model.n_joints())
            .map(|_| r.gen_range(-5.0..5.0))
            .collect();
        for mode in modes(model) {
            if data.prepare(model, &FlatGround, mode, &q, &qd).is_err() {
                continue;
            }
            let dc = data.dynamic_coords.clone();
            let mbar = data.m_bar.select_rows(&dc).select_columns(&dc);
            let a = data.constraints.a.select_columns(&dc);
            let (m, c) = (dc.len(), a.nrows());
            let force = data.generalized_force(model, &tau);
            let f: Vec<f64> = dc.iter().map(|&i| force[i]).collect();
            let g: Vec<f64> = (0..c).map(|_| r.gen_range(-1.0..1.0)).collect();
            let (mut x, mut y) = (vec![0.0; m], vec![0.0; c]);
            data.kkt.solve(&f, &g, &mut x, &mut y);
            tally.systems += 1;
            let range = data.kkt.is_range_space();
            if !range {
                continue;
            }
            assert!(m > SMALL_M, "range-space route at m = {m}");
            tally.range += 1;
            if data.kkt.route == Route::MasslessRange {
                tally.massless += 1;
            }
            let mut null = null_route(&mbar, &a).expect("null-space route regular");
            let (mut xn, mut yn) = (vec![0.0; m], vec![0.0; c]);
            null.solve(&f, &g, &mut xn, &mut yn);
            let (xd, yd) = kkt_solve_dense(
                &mbar,
                &a,
                &DVector::from_vec(f.clone()),
                &DVector::from_vec(g.clone()),
            )
            .expect("dense LU regular");
            // against the dense LU to 1e-10; against the null-space route as well, or the
            // difference is the null-space route's own error (as large against the LU: at a
            // condition number of 1e7 it reaches 1e-10 where the range-space routes do not)
            let pair = |u: &[f64], v: &[f64], w: &[f64], z: &[f64]| rel(u, v).max(rel(w, z));
            let worst = pair(&x, xd.as_slice(), &y, yd.as_slice());
            let from_null = pair(&x, &xn, &y, &yn);
            let null_own = pair(&xn, xd.as_slice(), &yn, yd.as_slice());
            assert!(worst < 1e-10, "m={m} c={c} {mode:?}: {worst:e}");
            assert!(
                from_null < 1e-10 || from_null < 2.0 * null_own,
                "m={m} c={c} {mode:?}: {from_null:e} from the null-space route ({null_own:e})"
            );
            tally.worst = tally.worst.max(worst);
            // the blocks (column by column through the solve)
            let (b, bn) = (data.kkt.blocks(), null.blocks());
            let inv = kkt_matrix(&mbar, &a).try_inverse().expect("dense inverse");
            let bd = KktBlocks {
                m_dagger: inv.view((0, 0), (m, m)).into_owned(),
                a_dagger: inv.view((m, 0), (c, m)).into_owned(),
                lambda: inv.view((m, m), (c, c)).into_owned(),
            };
            // Λ is zero on the rows' combinations massless coordinates take up: its
            // difference is measured against the size it has where nothing cancels,
            // ‖A†‖² / ‖M†‖ (a mass per squared row unit, as Λ), when that is larger
            let lambda_scale = if bd.m_dagger.norm() > 0.0 {
                bd.a_dagger.norm().powi(2) / bd.m_dagger.norm()
            } else {
                0.0
            };
            let diff = |u: &DMatrix<f64>, v: &DMatrix<f64>, floor: f64| {
                rel_above(u.as_slice(), v.as_slice(), floor)
            };
            for (name, u, v, w, floor) in [
                ("M†", &b.m_dagger, &bd.m_dagger, &bn.m_dagger, 0.0),
                ("A†", &b.a_dagger, &bd.a_dagger, &bn.a_dagger, 0.0),
                ("Λ", &b.lambda, &bd.lambda, &bn.lambda, lambda_scale),
            ] {
                let e = diff(u, v, floor);
                assert!(e < 1e-10, "{name}, m={m} c={c}: {e:e}");
                let (from_null, null_own) = (diff(u, w, floor), diff(w, v, floor));
                assert!(
                    from_null < 1e-10 || from_null < 2.0 * null_own,
                    "{name}, m={m} c={c}: {from_null:e} from the null-space route ({null_own:e})"
                );
            }
            // Λ = −S⁻¹ is symmetric negative definite; with massless coordinates
            // `Λ = −S⁻¹ + S⁻¹ B T⁻¹ Bᵀ S⁻¹` is negative semi-definite (zero on the rows'
            // combinations the massless coordinates take up)
            if c > 0 {
                let size = b.lambda.norm().max(lambda_scale);
                assert!((&b.lambda - b.lambda.transpose()).norm() < 1e-10 * size);
                if data.kkt.route == Route::RangeSpace {
                    assert!((-&b.lambda).cholesky().is_some());
                } else {
                    let top = b.lambda.symmetric_eigenvalues().max();
                    assert!(top < 1e-10 * size, "Λ's largest eigenvalue {top:e}");
                }
            }
            let bits = |v: &DMatrix<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&data.kkt.null_space_basis()),
                bits(&null.null_space_basis())
            );
            assert_eq!(data.kkt.info(), null.info);
            // asking for them leaves the solve's factors alone
            let (mut x2, mut y2) = (vec![0.0; m], vec![0.0; c]);
            data.kkt.solve(&f, &g, &mut x2, &mut y2);
            assert_eq!((x2, y2), (x.clone(), y.clone()));
            // the whole forward dynamics, sliding contacts' friction (its fold of the
            // non-symmetric system into solves of this one) included, on both routes
            let mut run = |null_only: bool| {
                NULL_SPACE_ONLY.with(|c| c.set(null_only));
                let out =
                    forward_dynamics(model, &mut data, &FlatGround, mode, &q, &qd, &tau, None)
                        .map(|()| (data.qdd.clone(), data.lambda.clone()));
                NULL_SPACE_ONLY.with(|c| c.set(false));
                out
            };
            match (run(false), run(true)) {
                (Ok((qdd, lambda)), Ok((qdd_n, lambda_n))) => {
                    let e = rel(qdd.as_slice(), qdd_n.as_slice())
                        .max(rel(lambda.as_slice(), lambda_n.as_slice()));
                    // to 1e-10, or on an ill-conditioned system to what a backward-stable
                    // solve promises there: its condition number times 10 unit round-offs
                    // (a sliding toe's friction folded in, no dense reference to take sides)
                    if e >= 1e-10 {
                        let tol = 10.0 * f64::EPSILON * kkt_condition_number(&mbar, &a);
                        assert!(e < tol, "forward dynamics, m={m} c={c} {mode:?}: {e:e}");
                    }
                    tally.dynamics += 1;
                }
                (Err(_), Err(_)) => {}
                (fast, slow) => panic!("{mode:?}: {:?} vs {:?}", fast.err(), slow.err()),
            }
        }
    }
}

/// The robots of `tests/data/robots` (up to six coordinates mostly: the null-space route,
/// which the range-space one must then leave alone).
#[test]
fn range_route_agrees_on_the_test_robots() {
    let mut r = ChaCha8Rng::seed_from_u64(70);
    let mut tally = Tally::default();
    for (name, model) in data_robots() {
        let before = tally.range;
        check_robot(&model, 3, &mut r, &mut tally);
        if model.nq() <= SMALL_M {
            assert_eq!(tally.range, before, "{name}");
        }
    }
    assert!(tally.systems > 100, "{}", tally.systems);
}

/// Random legged trees of 7 to 13 coordinates: the route is taken on most systems of
/// massive legs and agrees with the null-space route and the dense LU.
#[test]
fn range_route_agrees_on_random_legged_trees() {
    let mut r = ChaCha8Rng::seed_from_u64(477);
    let mut tally = Tally::default();
    for m in 7..=13 {
        for _ in 0..6 {
            let model = random_tree(m, &mut r);
            check_robot(&model, 3, &mut r, &mut tally);
        }
    }
    assert!(tally.dynamics * 2 > tally.range, "{}", tally.dynamics);
    assert!(
        tally.range * 3 > tally.systems,
        "{} of {}",
        tally.range,
        tally.systems
    );
    eprintln!(
        "range-space route on {} of {} systems, worst relative difference {:e}",
        tally.range, tally.systems, tally.worst
    );
}

/// Random legged trees with a massless link at a leg's end (a coordinate moving no mass):
/// the massless range-space route is taken on the systems whose rows hold that coordinate
/// (the leg's toe on the ground) and agrees with the null-space route and the dense LU
/// ([`check_robot`]).
#[test]
fn massless_route_agrees_on_random_legged_trees() {
    let mut r = ChaCha8Rng::seed_from_u64(421);
    let mut tally = Tally::default();
    let mut robots = 0;
    while robots < 24 {
        let m = r.gen_range(7..=13);
        let model = random_tree(m, &mut r);
        let zero = |j: &crate::model::Joint| j.mass_kg == 0.0 && j.inertia_kg_m2 == 0.0;
        let massless_end = model
            .legs
            .iter()
            .any(|leg| zero(&model.joints[leg.first_joint + leg.n_links - 1]));
        if !massless_end {
            continue;
        }
        robots += 1;
        check_robot(&model, 3, &mut r, &mut tally);
    }
    assert!(
        tally.massless * 4 > tally.range,
        "{} of {}",
        tally.massless,
        tally.range
    );
    assert!(tally.dynamics * 2 > tally.range, "{}", tally.dynamics);
    eprintln!(
        "massless route on {} of {} systems ({} on a range-space route), worst relative \
         difference {:e}",
        tally.massless, tally.systems, tally.range, tally.worst
    );
}

/// The range-space route's accuracy by its smallest pivot ratio, the route forced (no pivot
/// test): the measurement behind [`RANGE_PIVOT_FRACTION`] and [`RANGE_MASSLESS_DIAGONAL`]
/// (`cargo test --release -p selfmanip-core --lib range_route_accuracy -- --ignored
/// --nocapture`).
#[test]
#[ignore]
fn range_route_accuracy_by_pivot_ratio() {
    let mut r = ChaCha8Rng::seed_from_u64(1);
    // by decade of the smallest pivot ratio of M̄ (0..) and of S (20..)
    // and of M̄'s smallest diagonal entry to its largest (40..)
    let mut worst = [0.0f64; 60];
    let mut count = [0usize; 60];
    let mut grid = [[(0usize, 0.0f64); 5]; 5];
    for m in 7..=13 {
        for _ in 0..25 {
            let model = random_tree(m, &mut r);
            let mut data = Data::new(&model);
            for _ in 0..2 {
                let nq = model.nq();
                let q: Vec<f64> = (0..nq).map(|_| r.gen_range(-1.5..1.5)).collect();
                let qd: Vec<f64> = (0..nq).map(|_| r.gen_range(-2.0..2.0)).collect();
                for mode in modes(&model) {
                    if data.prepare(&model, &FlatGround, mode, &q, &qd).is_err() {
                        continue;
                    }
                    let dc = data.dynamic_coords.clone();
                    let mbar = data.m_bar.select_rows(&dc).select_columns(&dc);
                    let a = data.constraints.a.select_columns(&dc);
                    let (m, c) = (dc.len(), a.nrows());
                    let Ok(mut null) = null_route(&mbar, &a) else {
                        continue;
                    };
                    let mut k = KktFactorization::default();
                    k.load(&mbar, &a, None);
                    if !with_dims!(m, c, |md, cd| range_factor_kernel(md, cd, &mut k, 0.0, 0.0)) {
                        continue;
                    }
                    k.route = Route::RangeSpace;
                    let ratio_m = (0..m)
                        .map(|j| 1.0 / k.ml_inv[j].powi(2) / k.mbar[j * m + j])
                        .fold(1.0, f64::min);
                    let ratio_s = (0..c)
                        .map(|j| {
                            let zj = &k.z[j * m..(j + 1) * m];
                            1.0 / k.sl_inv[j].powi(2) / zj.iter().map(|v| v * v).sum::<f64>()
                        })
                        .fold(1.0, f64::min);
                    let f: Vec<f64> = (0..m).map(|_| r.gen_range(-1.0..1.0)).collect();
                    let g: Vec<f64> = (0..c).map(|_| r.gen_range(-1.0..1.0)).collect();
                    let (mut x, mut y) = (vec![0.0; m], vec![0.0; c]);
                    let (mut xn, mut yn) = (vec![0.0; m], vec![0.0; c]);
                    k.solve(&f, &g, &mut x, &mut y);
                    null.solve(&f, &g, &mut xn, &mut yn);
                    let e = rel(&x, &xn).max(rel(&y, &yn));
                    let bm = (-ratio_m.log10()).floor().clamp(0.0, 19.0) as usize;
                    let bs = 20 + (-ratio_s.log10()).floor().clamp(0.0, 19.0) as usize;
                    let diag = (0..m).map(|j| k.mbar[j * m + j]);
                    let ratio_d =
                        diag.clone().fold(f64::INFINITY, f64::min) / diag.fold(0.0, f64::max);
                    let bd = 40 + (-ratio_d.log10()).floor().clamp(0.0, 19.0) as usize;
                    for (i, td) in [1e-3, 1e-4, 1e-5, 1e-6, 1e-7].into_iter().enumerate() {
                        for (j, ts) in [1e-2, 1e-4, 1e-6, 1e-8, 0.0].into_iter().enumerate() {
                            if ratio_d > td && ratio_s > ts && ratio_m > 1e-3 {
                                grid[i][j].0 += 1;
                                grid[i][j].1 = grid[i][j].1.max(e);
                            }
                        }
                    }
                    for b in [bm, bs, bd] {
                        worst[b] = worst[b].max(e);
                        count[b] += 1;
                    }
                }
            }
        }
    }
    println!("{grid:?}");
    for b in 0..60 {
        if count[b] > 0 {
            let (what, d) = match b {
                0..20 => ("M̄ pivot", b),
                20..40 => ("S pivot", b - 20),
                _ => ("M̄ diagonal", b - 40),
            };
            println!(
                "{what} ratio 1e-{} .. 1e-{d}: {} systems, worst {:.2e}",
                d + 1,
                count[b],
                worst[b]
            );
        }
    }
}

/// A legged system's `M̄` (body `x, z, φ` last, legs of two joints coupled to the body and
/// within the leg only) with every diagonal entry clearly positive, and `c` rows each on
/// the body and one leg.
fn legged_pd(m: usize, c: usize, r: &mut ChaCha8Rng) -> (DMatrix<f64>, DMatrix<f64>) {
    let joints = m - 3;
    let leg = |p: usize| (p < joints).then_some(p / 2);
    let on = |p: usize, l: usize| leg(p).is_none_or(|k| k == l);
    let mut b = DMatrix::zeros(m + 2, m);
    for i in 0..m + 2 {
        let l = r.gen_range(0..joints.div_ceil(2));
        for p in (0..m).filter(|&p| on(p, l)) {
            b[(i, p)] = r.gen_range(-1.0..1.0);
        }
    }
    let mbar = b.transpose() * &b + DMatrix::identity(m, m) * 0.5;
    let mut a = DMatrix::zeros(c, m);
    for i in 0..c {
        let l = r.gen_range(0..joints.div_ceil(2));
        for p in (0..m).filter(|&p| on(p, l)) {
            a[(i, p)] = r.gen_range(-1.0..1.0);
        }
    }
    (mbar, a)
}

/// The range-space kernels compiled for fixed `(m, c)` (every `c` up to `m`) give the run-time-size kernels'
/// factors and solution bit for bit.
#[test]
fn fixed_size_range_kernels_are_bit_identical_to_run_time_ones() {
    let mut r = ChaCha8Rng::seed_from_u64(178);
    let (mut fixed, mut dynamic) = (KktFactorization::default(), KktFactorization::default());
    for m in 7..=13 {
        for c in 0..=m {
            let (mbar, _) = legged_pd(m, 0, &mut r);
            // rows on every coordinate: independent up to c = m
            let a = DMatrix::from_fn(c, m, |_, _| r.gen_range(-1.0..1.0));
            fixed.factor(&mbar, &a).unwrap();
            dynamic.load(&mbar, &a, None);
            let (floor, pivot) = (RANGE_MASSLESS_DIAGONAL, RANGE_PIVOT_FRACTION);
            let taken = range_factor_kernel(m, c, &mut dynamic, floor, pivot);
            assert_eq!(taken, fixed.is_range_space(), "m={m} c={c}");
            if !taken {
                // a random square A can be too ill-conditioned for the route
                assert!(c + 2 >= m, "m={m} c={c}");
                continue;
            }
            assert_same_bits(
                &[
                    ("L", &fixed.ml, &dynamic.ml),
                    ("1/L_jj", &fixed.ml_inv, &dynamic.ml_inv),
                    ("Z", &fixed.z, &dynamic.z),
                    ("C", &fixed.sl, &dynamic.sl),
                    ("1/C_jj", &fixed.sl_inv, &dynamic.sl_inv),
                ],
                &format!("m={m} c={c}"),
            );
            let f: Vec<f64> = (0..m).map(|_| r.gen_range(-1.0..1.0)).collect();
            let g: Vec<f64> = (0..c).map(|_| r.gen_range(-1.0..1.0)).collect();
            let (mut x1, mut y1) = (vec![0.0; m], vec![0.0; c]);
            let (mut x2, mut y2) = (vec![0.0; m], vec![0.0; c]);
            fixed.solve(&f, &g, &mut x1, &mut y1);
            range_solve_kernel(m, c, &dynamic, &f, &g, &mut x2, &mut y2);
            let case = format!("m={m} c={c}");
            assert_same_bits(&[("x", &x1, &x2), ("y", &y1, &y2)], &case);
        }
    }
}

/// The route choice: beyond six coordinates a clearly positive definite `M̄` with
/// independent rows takes the range-space route, and one with massless coordinates the
/// rows hold the massless range-space route; a massless coordinate no row holds, more
/// massless coordinates than rows, more rows than massive coordinates, a nearly massless
/// coordinate, dependent or nearly
/// dependent rows, more rows than coordinates, a non-finite `M̄` or `A`, and any system of
/// up to six coordinates take the null-space route, with its outcome (the same typed error
/// where it fails).
#[test]
fn route_choice() {
    let mut r = ChaCha8Rng::seed_from_u64(406);
    let mut k = KktFactorization::default();
    for m in 7..=13 {
        let (mbar, a) = legged_pd(m, 4, &mut r);
        k.factor(&mbar, &a).unwrap();
        assert!(k.is_range_space(), "m={m}");
        let null_outcome = |mbar: &DMatrix<f64>, a: &DMatrix<f64>| null_route(mbar, a).err();
        // a massless coordinate the rows hold: the massless range-space route, which
        // agrees with the null-space one; one no row holds: the null-space route's outcome
        let mut massless = mbar.clone();
        massless.row_mut(1).fill(0.0);
        massless.column_mut(1).fill(0.0);
        let mut held = a.clone();
        held[(0, 1)] = 1.0;
        k.factor(&massless, &held).unwrap();
        assert_eq!(k.route, Route::MasslessRange, "m={m}");
        let mut null = null_route(&massless, &held).unwrap();
        let f: Vec<f64> = (0..m).map(|_| r.gen_range(-1.0..1.0)).collect();
        let g: Vec<f64> = (0..4).map(|_| r.gen_range(-1.0..1.0)).collect();
        let (mut x, mut y, mut xn, mut yn) =
            (vec![0.0; m], vec![0.0; 4], vec![0.0; m], vec![0.0; 4]);
        k.solve(&f, &g, &mut x, &mut y);
        null.solve(&f, &g, &mut xn, &mut yn);
        assert!(rel(&x, &xn).max(rel(&y, &yn)) < 1e-10, "m={m}");
        let mut unheld = held.clone();
        unheld.column_mut(1).fill(0.0);
        let cases: Vec<(&str, DMatrix<f64>, DMatrix<f64>)> = vec![
            ("massless, no row holds it", massless.clone(), unheld),
            ("massless, more rows than coordinates", massless.clone(), {
                let mut d = DMatrix::from_fn(m + 1, m, |_, _| r.gen_range(-1.0..1.0));
                d[(0, 1)] = 1.0;
                d
            }),
            (
                "two massless, one row",
                {
                    let mut mb = massless.clone();
                    mb.row_mut(2).fill(0.0);
                    mb.column_mut(2).fill(0.0);
                    mb
                },
                held.rows(0, 1).into_owned(),
            ),
            (
                "nearly massless",
                {
                    let mut mb = mbar.clone();
                    mb.row_mut(0).iter_mut().for_each(|x| *x *= 1e-4);
                    mb.column_mut(0).iter_mut().for_each(|x| *x *= 1e-4);
                    mb
                },
                a.clone(),
            ),
            ("dependent rows", mbar.clone(), {
                let mut d = a.clone();
                d.set_row(1, &a.row(0));
                d
            }),
            ("nearly dependent rows", mbar.clone(), {
                let mut d = a.clone();
                let row = a.row(0) * (1.0 + 1e-5);
                d.set_row(1, &row);
                d[(1, m - 1)] += 1e-5;
                d
            }),
            ("more rows than coordinates", mbar.clone(), {
                DMatrix::from_fn(m + 1, m, |_, _| r.gen_range(-1.0..1.0))
            }),
            (
                "non-finite M̄",
                {
                    let mut mb = mbar.clone();
                    mb[(m - 1, 0)] = f64::NAN;
                    mb
                },
                a.clone(),
            ),
            ("non-finite A", mbar.clone(), {
                let mut d = a.clone();
                d[(2, m - 2)] = f64::INFINITY;
                d
            }),
        ];
        for (name, mb, ac) in cases {
            let got = k.factor(&mb, &ac);
            assert!(!k.is_range_space(), "{name}, m={m}");
            match (got, null_outcome(&mb, &ac)) {
                (Ok(()), None) => {}
                (Err(CoreError::SingularKkt { kind, .. }), Some(expect)) => {
                    assert_eq!(kind, expect, "{name}, m={m}")
                }
                (got, expect) => panic!("{name}, m={m}: {got:?} vs {expect:?}"),
            }
        }
    }
    // up to six coordinates: the null-space route, whatever the system
    for m in 3..=6 {
        for c in 0..=m {
            let (mbar, a) = legged_pd(m.max(4), c.min(m), &mut r);
            let (mbar, a) = (
                mbar.view((0, 0), (m, m)).into_owned(),
                a.view((0, 0), (c, m)).into_owned(),
            );
            if k.factor(&mbar, &a).is_ok() {
                assert!(!k.is_range_space(), "m={m} c={c}");
            }
        }
    }
}
