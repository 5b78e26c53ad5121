//! The QP path for frictionless impact and liftoff complementarity (thesis (5.19)–(5.20),
//! (5.28)–(5.29), pseudo-impulse (5.39)–(5.40)) against independent routes:
//! - a brute-force enumeration written here from the core's `plastic_impact`,
//!   `pseudo_impulse`, `forward_dynamics` and KKT blocks (every subset of the candidates;
//!   accept it when its impulses push and every left-out contact separates), on seeded random
//!   polygons whose contact points each touch their own tilted ground facet;
//! - closed forms for a flat-bottomed body with 16–24 contact points (far beyond enumeration);
//! - a robot with a massive and a massless leg;
//! - bad input and solver failure as typed errors.
//!
//! Timing: `cargo test --release -p selfmanip-hybrid --test impact_qp -- --nocapture` prints the
//! cost of one 16-contact impact QP.
use nalgebra::DVector;
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::{
    forward_dynamics, plastic_impact, pseudo_impulse, ContactKind, ContactMode, CoreError, Data,
    FlatGround, GroundPlane, Model, RobotDescription, Terrain,
};
use selfmanip_hybrid::impact_qp::{
    frictionless_impact, frictionless_impact_with, frictionless_liftoff, ContactQpError,
    ContactQpOptions, QpOutcome,
};

const G: f64 = 9.81;

/// SplitMix64: a seeded generator without a dev-dependency.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
    /// One uniform draw in each `(lo, hi)`, in order.
    fn within(&mut self, bounds: &[(f64, f64)]) -> Vec<f64> {
        bounds
            .iter()
            .map(|&(lo, hi)| self.uniform(lo, hi))
            .collect()
    }
}

/// A rigid body with frictionless point contacts at `points` (body frame, z down).
fn polygon(mass_kg: f64, inertia_kg_m2: f64, points: &[[f64; 2]]) -> Model {
    RobotDescription::from_toml_str(&polygon_toml(mass_kg, inertia_kg_m2, points))
        .unwrap()
        .build()
        .unwrap()
}

/// The description of a flat-bottomed body's points at `xs`, depth `h` (3 kg, 0.05 kg m²).
fn model_toml(xs: &[f64], h: f64) -> String {
    let pts: Vec<[f64; 2]> = xs.iter().map(|&x| [x, h]).collect();
    polygon_toml(3.0, 0.05, &pts)
}

fn polygon_toml(mass_kg: f64, inertia_kg_m2: f64, points: &[[f64; 2]]) -> String {
    let mut s = format!(
        "name = \"polygon\"\ngravity_m_s2 = {G}\nlegs = []\n[body]\nmass_kg = {mass_kg}\n\
         inertia_kg_m2 = {inertia_kg_m2}\n"
    );
    for (i, p) in points.iter().enumerate() {
        s += &format!(
            "[[contacts]]\nname = \"p{i}\"\nshape = {{ kind = \"point\", position_m = [{}, {}] }}\n\
             friction = {{ kind = \"sliding\" }}\n",
            p[0], p[1]
        );
    }
    s
}

/// Ground made of one facet per contact: the plane through the contact's world point with
/// its own tilt, chosen by the nearest stored x (so every contact touches, in general
/// position).
struct Facets(Vec<(f64, GroundPlane)>);

impl Terrain for Facets {
    fn plane_under(&self, x_m: f64) -> GroundPlane {
        self.0
            .iter()
            .min_by(|a, b| (a.0 - x_m).abs().total_cmp(&(b.0 - x_m).abs()))
            .expect("facets")
            .1
    }
}

/// Facets through the world points of `contacts` at `q`, tilted by `tilts` (rad), or `None`
/// when two contacts are too close in x to tell their facets apart.
fn facets(model: &Model, q: &[f64], contacts: &[usize], tilts: &[f64]) -> Option<Facets> {
    let mut data = Data::new(model);
    data.kin.compute(model, q, &vec![0.0; q.len()]);
    let pts: Vec<_> = contacts
        .iter()
        .map(|&k| contact_geometry(model, &data.kin, &FlatGround, k).point)
        .collect();
    for i in 0..pts.len() {
        for j in 0..i {
            if (pts[i].x - pts[j].x).abs() < 0.01 {
                return None;
            }
        }
    }
    Some(Facets(
        pts.iter()
            .zip(tilts)
            .map(|(p, &b)| {
                (
                    p.x,
                    GroundPlane {
                        point_m: [p.x, p.y],
                        normal_into_ground: [b.sin(), b.cos()],
                    },
                )
            })
            .collect(),
    ))
}

fn slide(contacts: &[usize]) -> ContactMode {
    contacts
        .iter()
        .fold(ContactMode::FLIGHT, |m, &k| m.with(k, ContactKind::Slide))
}

fn members(mode: ContactMode) -> Vec<usize> {
    mode.active().collect()
}

/// One accepted subset of the brute force: its contacts, plastic `q̇⁺`, `P_λ` and `P_δ`
/// (rows of the subset's mode).
struct Accepted {
    set: Vec<usize>,
    qd_plus: DVector<f64>,
    impulse: Vec<f64>,
    pseudo: Vec<f64>,
}

/// Brute-force impulse–velocity complementarity from the core alone. A subset `J` is
/// accepted when its mode's KKT system is regular, every normal impulse pushes —
/// `U(P_λ) ≥ 0`, or `U(P_λ + P_δ) ≥ 0` with the pseudo-impulse — and every left-out contact
/// separates: `A_k q̇⁺ ≥ 0`, or with the pseudo-impulse `A_k (q̇⁺ + δt M†_J f) ≥ 0` (the
/// velocity after the impact plus `δt` of the smooth motion in `J`, thesis (5.3)/(5.38)).
fn brute_force_impact(
    model: &Model,
    terrain: &dyn Terrain,
    cand: &[usize],
    q: &[f64],
    qd: &[f64],
    pseudo: Option<(&[f64], f64)>,
) -> Vec<Accepted> {
    let mut data = Data::new(model);
    data.prepare_geometry(model, terrain, slide(cand), q, qd)
        .unwrap();
    let a_all = data.constraints.a.clone();
    let v_scale = (&a_all * DVector::from_column_slice(qd)).amax();
    let p_scale = model.total_mass_kg() * v_scale;
    let mut out = Vec::new();
    for bits in 0u32..(1 << cand.len()) {
        let set: Vec<usize> = (0..cand.len())
            .filter(|i| bits >> i & 1 == 1)
            .map(|i| cand[i])
            .collect();
        let mode = slide(&set);
        let imp = match plastic_impact(model, &mut data, terrain, mode, q, qd) {
            Ok(i) => i,
            Err(CoreError::SingularKkt { .. }) => continue,
            Err(e) => panic!("{e}"),
        };
        let mut total: Vec<f64> = imp.impulse.iter().copied().collect();
        let mut pd = Vec::new();
        let mut v = imp.qd_plus.clone();
        if let Some((tau, dt)) = pseudo {
            pd = pseudo_impulse(model, &mut data, terrain, mode, q, qd, tau, dt)
                .unwrap()
                .iter()
                .copied()
                .collect();
            total.iter_mut().zip(&pd).for_each(|(t, p)| *t += p);
            data.prepare(model, terrain, mode, q, qd).unwrap();
            let md = data.kkt.blocks().m_dagger;
            let f = data.generalized_force(model, tau);
            let fd = DVector::from_iterator(
                data.dynamic_coords.len(),
                data.dynamic_coords.iter().map(|&c| f[c]),
            );
            let x = md * fd;
            for (i, &c) in data.dynamic_coords.iter().enumerate() {
                v[c] += dt * x[i];
            }
        }
        if total.iter().any(|&p| -p < -1e-9 * p_scale) {
            continue;
        }
        let sep = (0..cand.len())
            .filter(|i| bits >> i & 1 == 0)
            .all(|i| (a_all.row(i) * &v)[0] >= -1e-9 * v_scale);
        if sep {
            out.push(Accepted {
                set,
                qd_plus: imp.qd_plus,
                impulse: imp.impulse.iter().copied().collect(),
                pseudo: pd,
            });
        }
    }
    out
}

/// A random polygon with `n` contacts, each on its own tilted facet, and an incoming velocity.
fn random_case(rng: &mut Rng, n: usize) -> (Model, Facets, Vec<f64>, Vec<f64>) {
    loop {
        let mass = rng.uniform(1.0, 5.0);
        let inertia = mass * rng.uniform(0.01, 0.06);
        let points: Vec<[f64; 2]> = (0..n)
            .map(|_| [rng.uniform(-0.3, 0.3), rng.uniform(-0.1, 0.15)])
            .collect();
        let model = polygon(mass, inertia, &points);
        let q = vec![rng.uniform(-0.1, 0.1), -0.2, rng.uniform(-0.4, 0.4)];
        let tilts: Vec<f64> = (0..n).map(|_| rng.uniform(-0.6, 0.6)).collect();
        let cand: Vec<usize> = (0..n).collect();
        let Some(terrain) = facets(&model, &q, &cand, &tilts) else {
            continue;
        };
        let qd = rng.within(&[(-1.0, 1.0), (-0.5, 1.5), (-4.0, 4.0)]);
        return (model, terrain, q, qd);
    }
}

fn assert_close(a: &[f64], b: &[f64], tol: f64, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= tol,
            "{what}[{i}]: {x} vs {y} (tol {tol:.1e})"
        );
    }
}

/// The impulses of the candidates in `set` taken from rows of `set`'s mode, zero elsewhere.
fn per_candidate(cand: &[usize], set: &[usize], rows: &[f64]) -> Vec<f64> {
    cand.iter()
        .map(|k| set.iter().position(|s| s == k).map_or(0.0, |i| rows[i]))
        .collect()
}

#[test]
fn agrees_with_brute_force_enumeration_on_random_polygons() {
    let mut rng = Rng(0x5eed_0001);
    let (mut unique, mut ambiguous, mut multi) = (0, 0, 0);
    for case in 0..400 {
        let n = 1 + case % 8;
        let (model, terrain, q, qd) = random_case(&mut rng, n);
        let cand: Vec<usize> = (0..n).collect();
        let accepted = brute_force_impact(&model, &terrain, &cand, &q, &qd, None);
        assert!(
            !accepted.is_empty(),
            "case {case}: a frictionless impact has a solution"
        );
        let mut data = Data::new(&model);
        let out = frictionless_impact(&model, &mut data, &terrain, &cand, &q, &qd, None)
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
        let s = out.solution();
        let v_tol = 1e-8 * (1.0 + qd.iter().fold(0.0f64, |a, b| a.max(b.abs())));
        // q̇⁺ is unique: every accepted subset gives the QP's
        for a in &accepted {
            assert_close(
                a.qd_plus.as_slice(),
                s.qd_plus.as_slice(),
                v_tol,
                &format!("case {case} q̇⁺ of {:?}", a.set),
            );
        }
        assert!(
            accepted.iter().any(|a| a.set == members(s.set.mode)),
            "case {case}: the QP's set {:?} is one the enumeration accepts",
            members(s.set.mode)
        );
        // the QP's support contains every contact that pushes in some solution
        for a in &accepted {
            for (i, &k) in a.set.iter().enumerate() {
                if -a.impulse[i] > 1e-7 * model.total_mass_kg() {
                    assert!(
                        s.set.active.contains(&k),
                        "case {case}: {k} pushes in {:?}",
                        a.set
                    );
                }
            }
        }
        match &out {
            QpOutcome::Unique(_) => {
                assert_eq!(accepted.len(), 1, "case {case}: unique outcome");
                let a = &accepted[0];
                let p_tol = 1e-8 * model.total_mass_kg() * (1.0 + v_tol);
                assert_close(
                    &s.impulse,
                    &per_candidate(&cand, &a.set, &a.impulse),
                    p_tol,
                    &format!("case {case} impulse"),
                );
                unique += 1;
                multi += usize::from(a.set.len() >= 2);
            }
            QpOutcome::Ambiguous(_, amb) => {
                assert!(
                    accepted.len() > 1,
                    "case {case}: ambiguity {amb:?} but one accepted set"
                );
                ambiguous += 1;
            }
        }
    }
    eprintln!(
        "random polygons: {unique} unique ({multi} with ≥ 2 contacts), {ambiguous} ambiguous"
    );
    assert!(unique > 200 && multi > 50 && ambiguous > 5);
}

#[test]
fn pseudo_impulse_agrees_with_brute_force_rule_5_40() {
    let mut rng = Rng(0x5eed_0002);
    let dt = 0.05;
    let (mut unique, mut held_by_pseudo) = (0, 0);
    for case in 0..300 {
        let n = 2 + case % 6;
        let (model, terrain, q, mut qd) = random_case(&mut rng, n);
        // slow impacts, so that δt of gravity matters
        qd.iter_mut().for_each(|v| *v *= 0.2);
        let cand: Vec<usize> = (0..n).collect();
        // no joints, no torques: the pseudo-impulse of the smooth forces alone over δt
        let pseudo = Some((&[][..], dt));
        let accepted = brute_force_impact(&model, &terrain, &cand, &q, &qd, pseudo);
        assert!(!accepted.is_empty(), "case {case}");
        let mut data = Data::new(&model);
        let out = frictionless_impact(&model, &mut data, &terrain, &cand, &q, &qd, pseudo)
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
        let s = out.solution();
        assert!(
            accepted.iter().any(|a| a.set == members(s.set.mode)),
            "case {case}: QP set {:?} not accepted",
            members(s.set.mode)
        );
        if out.is_unique() {
            assert_eq!(accepted.len(), 1, "case {case}");
            let a = &accepted[0];
            let p_tol = 1e-8 * model.total_mass_kg();
            assert_close(
                &s.impulse,
                &per_candidate(&cand, &a.set, &a.impulse),
                p_tol,
                "P_λ",
            );
            assert_close(
                &s.pseudo_impulse,
                &per_candidate(&cand, &a.set, &a.pseudo),
                p_tol,
                "P_δ",
            );
            assert_close(s.qd_plus.as_slice(), a.qd_plus.as_slice(), 1e-9, "q̇⁺");
            unique += 1;
            held_by_pseudo += usize::from(a.impulse.iter().any(|&p| -p < 0.0));
        } else {
            assert!(accepted.len() > 1, "case {case}");
        }
    }
    eprintln!(
        "pseudo-impulse: {unique} unique, {held_by_pseudo} with a contact that only P_δ holds"
    );
    assert!(unique > 150 && held_by_pseudo > 5);
}

/// `n` points evenly on the flat bottom `z = +h` (body frame) between `x = ±half_width`.
fn flat_bottom(n: usize, half_width: f64, h: f64, mass: f64, inertia: f64) -> (Model, Vec<f64>) {
    let xs: Vec<f64> = (0..n)
        .map(|i| -half_width + 2.0 * half_width * i as f64 / (n - 1) as f64)
        .collect();
    let pts: Vec<[f64; 2]> = xs.iter().map(|&x| [x, h]).collect();
    (polygon(mass, inertia, &pts), xs)
}

/// A flat-bottomed body lands flat on level ground with `q̇⁻ = (ẋ, ż, φ̇)`, every bottom point
/// touching. Closed form (z down, φ nose-up, point velocity `v + φ̇ S(r)`, `S(r) = (r_z, −r_x)`):
/// a bottom point at `r = (xᵢ, h)` falls at `ż − φ̇ xᵢ`; an upward push `pᵢ ≥ 0` there changes
/// the momenta by `m Δż = −Σpᵢ` and `I Δφ̇ = Σpᵢ xᵢ` (the moment of the force `(0, −pᵢ)` about
/// `+y` is `F_x r_z − F_z r_x`); frictionless, so `ẋ` is kept. If every point stops, two
/// distinct `xᵢ` force `ż⁺ = φ̇⁺ = 0`, hence `Σpᵢ = m ż⁻` and `Σpᵢxᵢ = −I φ̇⁻`: feasible with
/// `p ≥ 0` iff the centre of pressure `−I φ̇⁻ / (m ż⁻)` lies in `[x_min, x_max]`. The
/// distribution among ≥ 3 collinear points is not unique (rank 2): an ambiguous outcome.
#[test]
fn large_flat_landing_stops_the_body_closed_form() {
    for &n in &[16usize, 20, 24] {
        let (m, i_b, h) = (3.0, 0.05, 0.04);
        let (model, xs) = flat_bottom(n, 0.4, h, m, i_b);
        let q = [0.3, -h, 0.0];
        let qd = [0.7, 1.2, -2.0];
        let cop = -i_b * qd[2] / (m * qd[1]);
        assert!(
            cop.abs() < 0.4,
            "centre of pressure {cop} inside the support"
        );
        let cand: Vec<usize> = (0..n).collect();
        let mut data = Data::new(&model);
        let out =
            frictionless_impact(&model, &mut data, &FlatGround, &cand, &q, &qd, None).unwrap();
        let QpOutcome::Ambiguous(s, amb) = &out else {
            panic!("collinear points: expected an ambiguous outcome, got {out:?}")
        };
        assert_eq!(
            amb.dependent, cand,
            "every point carries impulse in some solution"
        );
        assert_eq!(amb.dependent_rank, 2);
        assert!(amb.ties.is_empty());
        assert_eq!(s.set.active, cand);
        assert_close(s.qd_plus.as_slice(), &[qd[0], 0.0, 0.0], 1e-12, "q̇⁺");
        // the basic solution: two points bracketing the centre of pressure, pushing
        let basis = members(s.set.mode);
        assert_eq!(basis.len(), 2, "{basis:?}");
        assert!(
            xs[basis[0]] <= cop && cop <= xs[basis[1]],
            "{basis:?} vs {cop}"
        );
        let push: Vec<f64> = s.impulse.iter().map(|p| -p).collect();
        assert!(push.iter().all(|&p| p >= -1e-12));
        let total: f64 = push.iter().sum();
        let moment: f64 = push.iter().zip(&xs).map(|(p, x)| p * x).sum();
        assert!((total - m * qd[1]).abs() < 1e-12, "Σp = {total}");
        assert!((moment + i_b * qd[2]).abs() < 1e-12, "Σpx = {moment}");
        assert!(s.normal_velocity.iter().all(|v| v.abs() < 1e-12));
        // the basis mode is regular: the core's impact into it gives the same reset
        let imp = plastic_impact(&model, &mut data, &FlatGround, s.set.mode, &q, &qd).unwrap();
        assert_close(
            imp.qd_plus.as_slice(),
            s.qd_plus.as_slice(),
            1e-12,
            "core q̇⁺",
        );
    }
}

/// The same body with a fast nose-down spin: the centre of pressure would leave the support,
/// so the body pivots about its front point `x_f` alone. Closed form (same conventions):
/// `0 = ż⁺ − φ̇⁺ x_f`, `ż⁺ = ż⁻ − p/m`, `φ̇⁺ = φ̇⁻ + p x_f / I` give
/// `p = (ż⁻ − φ̇⁻ x_f) / (1/m + x_f²/I)`; every other point then rises at `−φ̇⁺ (x_f − xᵢ) > 0`
/// when `φ̇⁺ < 0`. Unique although 20 candidates rule out enumeration.
#[test]
fn large_flat_landing_with_fast_spin_pivots_on_one_point_closed_form() {
    let n = 20;
    let (m, i_b, h) = (3.0, 0.05, 0.04);
    let (model, xs) = flat_bottom(n, 0.4, h, m, i_b);
    let q = [0.0, -h, 0.0];
    let qd = [0.2, 0.5, -20.0];
    let xf = xs[n - 1];
    let p = (qd[1] - qd[2] * xf) / (1.0 / m + xf * xf / i_b);
    let (zd, phid) = (qd[1] - p / m, qd[2] + p * xf / i_b);
    assert!(phid < -0.5, "keeps spinning nose-down: {phid}");
    let cand: Vec<usize> = (0..n).collect();
    let mut data = Data::new(&model);
    let out = frictionless_impact(&model, &mut data, &FlatGround, &cand, &q, &qd, None).unwrap();
    let QpOutcome::Unique(s) = &out else {
        panic!("expected unique, got {out:?}")
    };
    assert_eq!(members(s.set.mode), vec![n - 1]);
    assert_eq!(s.set.active, vec![n - 1]);
    assert_close(s.qd_plus.as_slice(), &[qd[0], zd, phid], 1e-12, "q̇⁺");
    assert!((-s.impulse[n - 1] - p).abs() < 1e-12);
    for (i, &x) in xs.iter().enumerate().take(n - 1) {
        assert!(s.impulse[i] == 0.0);
        let v = -phid * (xf - x);
        assert!((s.normal_velocity[i] - v).abs() < 1e-12, "point {i}");
    }
}

/// A tie: a body falls straight down onto a floor point under its centre of mass, while a
/// point level with the centre of mass touches a vertical wall. The floor impulse `m ż⁻`
/// passes through the centre of mass, so nothing rotates and the wall point keeps zero
/// normal velocity with zero impulse: keeping or dropping it are both complementary (the
/// brute force accepts both). Reported as a tie and kept in the mode, as the enumeration's
/// strict (5.29) keeps it.
#[test]
fn tie_is_reported_and_kept_in_the_mode() {
    let (m, i_b, h) = (2.0, 0.03, 0.05);
    let model = polygon(m, i_b, &[[0.0, h], [0.1, 0.0]]);
    let q = [0.0, -h, 0.0];
    let qd = [0.0, 0.8, 0.0];
    let terrain = Facets(vec![
        (0.0, GroundPlane::level(0.0)),
        (
            0.1,
            GroundPlane {
                point_m: [0.1, -h],
                normal_into_ground: [1.0, 0.0],
            },
        ),
    ]);
    let cand = [0usize, 1];
    let accepted = brute_force_impact(&model, &terrain, &cand, &q, &qd, None);
    let sets: Vec<_> = accepted.iter().map(|a| a.set.clone()).collect();
    assert_eq!(sets, vec![vec![0], vec![0, 1]]);
    let mut data = Data::new(&model);
    let out = frictionless_impact(&model, &mut data, &terrain, &cand, &q, &qd, None).unwrap();
    let QpOutcome::Ambiguous(s, amb) = &out else {
        panic!("{out:?}")
    };
    assert!(amb.dependent.is_empty());
    assert_eq!(amb.ties, vec![1]);
    assert_eq!(members(s.set.mode), vec![0, 1]);
    assert_eq!(s.set.active, vec![0]);
    assert!((s.impulse[0] + m * qd[1]).abs() < 1e-12);
    assert!(s.impulse[1].abs() < 1e-12);
    assert_close(s.qd_plus.as_slice(), &[0.0; 3], 1e-12, "q̇⁺");
}

/// Liftoff (5.19)–(5.20) at rest: the body stands on points at `x ∈ [0.1, 0.5]` with its
/// centre of mass at `x = 0`, outside the support, so it tips backwards about the rear point
/// `r = (x_r, h)`. Closed form: with the push `l` there, `m z̈ = m g − l`, `I φ̈ = l x_r` and the
/// pivot's vertical acceleration `z̈ − φ̈ x_r = 0` (no centripetal term at rest) give
/// `φ̈ = m g x_r / (m x_r² + I)`, `l = I φ̈ / x_r`; the other points accelerate upwards at
/// `φ̈ (xᵢ − x_r) > 0`.
#[test]
fn liftoff_of_a_tipping_body_closed_form() {
    let n = 18;
    let (m, i_b, h) = (2.0, 0.04, 0.05);
    let xs: Vec<f64> = (0..n)
        .map(|i| 0.1 + 0.4 * i as f64 / (n - 1) as f64)
        .collect();
    let pts: Vec<[f64; 2]> = xs.iter().map(|&x| [x, h]).collect();
    let model = polygon(m, i_b, &pts);
    let q = [0.0, -h, 0.0];
    let qd = [0.0; 3];
    let cand: Vec<usize> = (0..n).collect();
    let mut data = Data::new(&model);
    let out =
        frictionless_liftoff(&model, &mut data, &FlatGround, &cand, &q, &qd, &[], None).unwrap();
    let QpOutcome::Unique(s) = &out else {
        panic!("expected unique, got {out:?}")
    };
    let xr = xs[0];
    let phidd = m * G * xr / (m * xr * xr + i_b);
    let l = i_b * phidd / xr;
    assert_eq!(members(s.set.mode), vec![0]);
    assert!((-s.lambda[0] - l).abs() < 1e-10, "{} vs {l}", -s.lambda[0]);
    assert_close(s.qdd.as_slice(), &[0.0, phidd * xr, phidd], 1e-10, "q̈");
    for (a, x) in s.normal_acceleration.iter().zip(&xs).skip(1) {
        assert!(
            (a - phidd * (x - xr)).abs() < 1e-10,
            "{a} vs {}",
            phidd * (x - xr)
        );
    }
    // the core's dynamics in the chosen mode agree
    forward_dynamics(
        &model,
        &mut data,
        &FlatGround,
        s.set.mode,
        &q,
        &qd,
        &[],
        None,
    )
    .unwrap();
    assert_close(data.qdd.as_slice(), s.qdd.as_slice(), 1e-10, "core q̈");
}

/// Standing flat with the centre of mass above the support: every point may carry weight
/// (ambiguous, rank 2), `q̈ = 0`, and the forces sum to the weight with zero moment.
#[test]
fn liftoff_of_a_standing_body_is_ambiguous_with_zero_acceleration() {
    let (m, i_b, h) = (2.0, 0.04, 0.05);
    let (model, xs) = flat_bottom(20, 0.3, h, m, i_b);
    let cand: Vec<usize> = (0..20).collect();
    let (q, qd) = ([0.0, -h, 0.0], [0.0; 3]);
    let mut data = Data::new(&model);
    let out =
        frictionless_liftoff(&model, &mut data, &FlatGround, &cand, &q, &qd, &[], None).unwrap();
    let QpOutcome::Ambiguous(s, amb) = &out else {
        panic!("{out:?}")
    };
    assert_eq!(amb.dependent.len(), 20);
    assert!(s.qdd.iter().all(|a| a.abs() < 1e-10));
    let push: Vec<f64> = s.lambda.iter().map(|l| -l).collect();
    assert!((push.iter().sum::<f64>() - m * G).abs() < 1e-10);
    assert!(push.iter().zip(&xs).map(|(p, x)| p * x).sum::<f64>().abs() < 1e-10);
}

/// Liftoff at rest on random facets against a brute-force force–acceleration enumeration
/// (core `forward_dynamics` in every subset; accept when every force pushes and every
/// left-out contact's separation acceleration `A_k q̈ + Ȧ_k q̇` is non-negative).
#[test]
fn liftoff_agrees_with_brute_force_on_random_polygons() {
    let mut rng = Rng(0x5eed_0003);
    let mut unique = 0;
    for case in 0..200 {
        let n = 1 + case % 7;
        let (model, terrain, q, _) = random_case(&mut rng, n);
        let qd = vec![0.0; 3];
        let cand: Vec<usize> = (0..n).collect();
        let mut data = Data::new(&model);
        data.prepare_geometry(&model, &terrain, slide(&cand), &q, &qd)
            .unwrap();
        let a_all = data.constraints.a.clone();
        let f_scale = model.total_mass_kg() * G;
        let mut accepted = Vec::new();
        for bits in 0u32..(1 << n) {
            let set: Vec<usize> = (0..n).filter(|i| bits >> i & 1 == 1).collect();
            match forward_dynamics(&model, &mut data, &terrain, slide(&set), &q, &qd, &[], None) {
                Ok(()) => {}
                Err(CoreError::SingularKkt { .. }) => continue,
                Err(e) => panic!("{e}"),
            }
            let push_ok = data.lambda.iter().all(|&l| -l >= -1e-9 * f_scale);
            let sep_ok = (0..n)
                .filter(|i| bits >> i & 1 == 0)
                .all(|i| (a_all.row(i) * &data.qdd)[0] >= -1e-9 * G);
            if push_ok && sep_ok {
                accepted.push((set, data.qdd.clone(), data.lambda.clone()));
            }
        }
        assert!(!accepted.is_empty(), "case {case}");
        let out = frictionless_liftoff(&model, &mut data, &terrain, &cand, &q, &qd, &[], None)
            .unwrap_or_else(|e| panic!("case {case}: {e}"));
        let s = out.solution();
        for (set, qdd, _) in &accepted {
            assert_close(
                qdd.as_slice(),
                s.qdd.as_slice(),
                1e-8,
                &format!("q̈ of {set:?}"),
            );
        }
        if out.is_unique() {
            assert_eq!(accepted.len(), 1, "case {case}");
            let (set, _, lambda) = &accepted[0];
            assert_eq!(&members(s.set.mode), set);
            assert_close(
                &s.lambda,
                &per_candidate(&cand, set, lambda.as_slice()),
                1e-8 * f_scale,
                "λ",
            );
            unique += 1;
        } else {
            assert!(accepted.len() > 1, "case {case}");
        }
    }
    assert!(unique > 100, "{unique}");
}

/// A body on four bottom points with a massive one-link leg (its toe a candidate) and a
/// massless one-link leg (free in flight, not a candidate). The massless joint keeps its
/// velocity, the massive leg's toe enters the Delassus operator through its joint, and the
/// result matches the brute force; a candidate on the massless leg is a typed error.
#[test]
fn legs_massive_candidate_and_massless_bystander() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../tests/data/robots/heavy_and_light_legs.toml"
    );
    let model = RobotDescription::from_file(std::path::Path::new(path))
        .unwrap()
        .build()
        .unwrap();
    assert_eq!(model.nq(), 5);
    let mut rng = Rng(0x5eed_0004);
    let cand = [0usize, 2, 3, 4, 5];
    let mut checked = 0;
    while checked < 100 {
        let q = vec![
            rng.uniform(-0.8, 0.8),
            rng.uniform(-1.0, 1.0),
            0.0,
            -0.2,
            rng.uniform(-0.3, 0.3),
        ];
        let tilts: Vec<f64> = (0..cand.len()).map(|_| rng.uniform(-0.5, 0.5)).collect();
        let Some(terrain) = facets(&model, &q, &cand, &tilts) else {
            continue;
        };
        let qd = rng.within(&[
            (-5.0, 5.0),
            (-5.0, 5.0),
            (-1.0, 1.0),
            (-0.5, 1.5),
            (-3.0, 3.0),
        ]);
        let accepted = brute_force_impact(&model, &terrain, &cand, &q, &qd, None);
        let mut data = Data::new(&model);
        let out = frictionless_impact(&model, &mut data, &terrain, &cand, &q, &qd, None).unwrap();
        let s = out.solution();
        assert_eq!(
            s.qd_plus[1], qd[1],
            "the free massless joint keeps its velocity"
        );
        for a in &accepted {
            assert_close(a.qd_plus.as_slice(), s.qd_plus.as_slice(), 1e-8, "q̇⁺");
        }
        if out.is_unique() {
            assert_eq!(accepted.len(), 1);
            assert_eq!(accepted[0].set, members(s.set.mode));
        }
        checked += 1;
    }
    let q = [0.3, 0.3, 0.0, -0.2, 0.0];
    let err = frictionless_impact(
        &model,
        &mut Data::new(&model),
        &FlatGround,
        &[1, 2],
        &q,
        &[0.0; 5],
        None,
    )
    .unwrap_err();
    assert_eq!(err, ContactQpError::MasslessCandidate { contact: 1 });
}

#[test]
fn bad_input_is_a_typed_error() {
    let (model, _) = flat_bottom(16, 0.4, 0.04, 3.0, 0.05);
    let mut data = Data::new(&model);
    let q = [0.0, -0.04, 0.0];
    let qd = [0.0, 1.0, 0.0];
    let cand: Vec<usize> = (0..16).collect();
    let run = |data: &mut Data, cand: &[usize], q: &[f64], qd: &[f64], p: Option<(&[f64], f64)>| {
        frictionless_impact(&model, data, &FlatGround, cand, q, qd, p).unwrap_err()
    };
    assert!(matches!(
        run(&mut data, &cand, &q[..2], &qd, None),
        ContactQpError::Core(CoreError::WrongLength { field: "q", .. })
    ));
    assert!(matches!(
        run(&mut data, &cand, &q, &[0.0, f64::NAN, 0.0], None),
        ContactQpError::Core(CoreError::NonFinite { field: "qd", .. })
    ));
    assert!(matches!(
        run(&mut data, &[0, 16], &q, &qd, None),
        ContactQpError::InvalidCandidates { .. }
    ));
    assert!(matches!(
        run(&mut data, &[3, 1, 3], &q, &qd, None),
        ContactQpError::InvalidCandidates { .. }
    ));
    assert!(matches!(
        run(&mut data, &cand, &q, &qd, Some((&[], -0.01))),
        ContactQpError::InvalidArgument {
            field: "delta_t",
            ..
        }
    ));
    assert!(matches!(
        run(&mut data, &cand, &q, &qd, Some((&[1.0], 0.01))),
        ContactQpError::Core(CoreError::WrongLength { field: "tau", .. })
    ));
    let e = frictionless_liftoff(
        &model,
        &mut data,
        &FlatGround,
        &cand,
        &q,
        &qd,
        &[],
        Some(&[0.0]),
    )
    .unwrap_err();
    assert!(matches!(
        e,
        ContactQpError::Core(CoreError::WrongLength {
            field: "free_qdd",
            ..
        })
    ));
    // a solver stopped early is a typed failure, never a guess
    let one_iteration = ContactQpOptions {
        max_iterations: 1,
        ..ContactQpOptions::default()
    };
    let with_options = |data: &mut Data, qd: &[f64], options: &ContactQpOptions| {
        frictionless_impact_with(&model, data, &FlatGround, &cand, &q, qd, None, options)
            .unwrap_err()
    };
    let e = with_options(&mut data, &[0.0, 1.0, -2.0], &one_iteration);
    assert!(matches!(e, ContactQpError::SolverFailed { .. }), "{e:?}");
    let bad_tol = ContactQpOptions {
        zero_tolerance: f64::NAN,
        ..ContactQpOptions::default()
    };
    assert!(matches!(
        with_options(&mut data, &qd, &bad_tol),
        ContactQpError::InvalidArgument {
            field: "zero_tolerance",
            ..
        }
    ));
    // no candidates: nothing happens
    let out = frictionless_impact(&model, &mut data, &FlatGround, &[], &q, &qd, None).unwrap();
    assert!(out.is_unique() && out.solution().set.mode.is_flight());
    assert_eq!(out.solution().qd_plus.as_slice(), &qd);
}

/// Through `simulate`: a flat-bottomed body with 16 points released level at zero height
/// lands on all of them at once — beyond exact enumeration, so the QP decides — and since
/// three or more collinear points leave the impulse distribution open (rank 2, see
/// `large_flat_landing_stops_the_body_closed_form`) the execution ends with the typed
/// several-solutions outcome, carrying the QP's basic set: two points bracketing the centre
/// of mass (here under the centre). With sticking points instead the QP does not apply and
/// the error names the first one.
#[test]
fn simulate_hands_large_contact_sets_to_the_qp() {
    use selfmanip_hybrid::{simulate, HybridError, HybridOptions, Termination, ZeroTorque};
    let n = 16;
    let (model, xs) = flat_bottom(n, 0.4, 0.04, 3.0, 0.05);
    // released level at rest, its bottom points at zero height
    let drop = |model: &Model| {
        simulate(
            model,
            &FlatGround,
            &ZeroTorque,
            ContactMode::FLIGHT,
            &[0.0, -0.04, 0.0],
            &[0.0; 3],
            0.1,
            HybridOptions::default(),
        )
    };
    let exec = drop(&model).unwrap();
    let Termination::SeveralContactSolutions { candidates, .. } = &exec.termination else {
        panic!("expected several solutions, got {:?}", exec.termination)
    };
    let basis = members(candidates[0]);
    assert_eq!(basis.len(), 2, "{basis:?}");
    assert!(xs[basis[0]] <= 0.0 && 0.0 <= xs[basis[1]], "{basis:?}");

    let sticking = RobotDescription::from_toml_str(
        &model_toml(&xs, 0.04).replace("kind = \"sliding\"", "kind = \"sticking\", mu = 1.0"),
    )
    .unwrap()
    .build()
    .unwrap();
    let err = drop(&sticking).unwrap_err();
    assert!(
        matches!(err, HybridError::TooManyContacts { n: 16, sticking: 0 }),
        "{err:?}"
    );
}
