//! d = 2 inside d = 3 (issue 32): the six-legged spatial RHex with each pair's two legs in
//! the pair's state gives the planar three-pair RHex's `q̈`, `λ` (the pair's two forces
//! summed, against the planar leg's) and plastic impact in every planar contact mode
//! (`FB FL ML RB RL`, toes sticking, body ends sliding), with the toes on their points or the
//! C-legs rolling as the planar model finds them. Two routes: the planar core (its own
//! kinematics, `M̄`, contact geometry and KKT kernel) and the spatial one (URDF, CRBA, RNEA,
//! frame Jacobians); the map between their coordinates is
//! `selfmanip_core::spatial::rhex::{from_planar, velocity_to_planar, acceleration_to_planar,
//! force_to_planar}`, and on a planar base (the body in the world's x–z plane, `q = [x, z, θ,
//! hips]`) sign flips ([`Base`]).
use nalgebra::{DVector, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use selfmanip::core::contact::{row_direction, TouchKind};
use selfmanip::core::spatial::rhex::{self, RhexSixLegs, SIDES};
use selfmanip::core::spatial::{self as sp, PointContact, SpatialData, SpatialError, SpatialModel};
use selfmanip::core::{
    forward_dynamics, plastic_impact, CoreError, Data, FlatGround, SingularityKind,
};
use selfmanip::rhex::{LegPair, Rhex, RhexParams};

const PAIRS: [LegPair; 3] = [LegPair::Front, LegPair::Middle, LegPair::Rear];

fn planar(massive_legs: bool) -> Rhex {
    let params = RhexParams {
        pairs: PAIRS.to_vec(),
        ..RhexParams::default()
    };
    let params = if massive_legs {
        params.with_table_4_2_legs()
    } else {
        params
    };
    Rhex::new(params).unwrap()
}

/// The spatial robot of the planar one: Table 4.2's single leg on each side (the planar pair
/// is twice it), or massless legs, on a free-flying base.
fn spatial(massive_legs: bool) -> (RhexSixLegs, SpatialModel) {
    spatial_on(massive_legs, Base::FreeFlyer)
}

fn spatial_on(massive_legs: bool, base: Base) -> (RhexSixLegs, SpatialModel) {
    let p = if massive_legs {
        RhexSixLegs::table_4_2().with_table_4_2_legs()
    } else {
        RhexSixLegs::table_4_2()
    };
    let model = p.model_on(base.kind()).unwrap();
    (p, model)
}

/// The spatial robot's base, and the map of the planar RHex's coordinates onto it: a free
/// flyer by `rhex::{from_planar, velocity_to_planar, acceleration_to_planar}`; a planar base
/// moves in the world's x–z plane (z up) turned about `y` (left), so its `[x, z, θ]` are the
/// planar `[x, −z, −φ]` (NED, nose-up `φ`), and the hips follow at rate 3.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Base {
    FreeFlyer,
    Planar,
}

impl Base {
    fn kind(self) -> sp::BaseKind {
        match self {
            Base::FreeFlyer => sp::BaseKind::FreeFlyer,
            Base::Planar => sp::BaseKind::Planar,
        }
    }

    /// The base's rates: the first hip's.
    fn nb(self) -> usize {
        match self {
            Base::FreeFlyer => 6,
            Base::Planar => 3,
        }
    }

    fn state(self, q: &[f64], qd: &[f64]) -> (DVector<f64>, DVector<f64>) {
        if self == Base::FreeFlyer {
            return rhex::from_planar(q, qd).unwrap();
        }
        let at = |x: &[f64]| {
            let hips = (0..6).map(|k| x[k / 2]);
            DVector::from_iterator(9, [x[3], -x[4], -x[5]].into_iter().chain(hips))
        };
        (at(q), at(qd))
    }

    fn velocity_to_planar(self, q: &[f64], v: &[f64]) -> DVector<f64> {
        match self {
            Base::FreeFlyer => rhex::velocity_to_planar(q, v),
            Base::Planar => DVector::from_column_slice(&[v[3], v[5], v[7], v[0], -v[1], -v[2]]),
        }
    }

    fn acceleration_to_planar(self, q: &[f64], v: &[f64], a: &[f64]) -> (DVector<f64>, [f64; 3]) {
        match self {
            Base::FreeFlyer => rhex::acceleration_to_planar(q, v, a),
            Base::Planar => (self.velocity_to_planar(q, a), [a[4], a[6], a[8]]),
        }
    }

    /// The relative agreement with the planar core: 1e-12, and 1e-11 on a planar base, where a
    /// pair's two legs down give redundant rows (the same base columns, no roll or yaw to tell
    /// them apart) that the spatial engine solves on `A`'s row space by an SVD.
    fn tolerance(self) -> f64 {
        match self {
            Base::FreeFlyer => 1e-12,
            Base::Planar => 1e-11,
        }
    }

    /// The rates that leave the sagittal plane (`y`, roll, yaw): none on a planar base.
    fn out_of_plane(self) -> &'static [usize] {
        match self {
            Base::FreeFlyer => &[1, 3, 5],
            Base::Planar => &[],
        }
    }
}

/// The spatial contacts of the planar mode just prepared in `data`: per active planar site
/// (in its geometry order) the left and right sites of the pair, a leg held in the sagittal
/// plane (rows world `x`, `z`) on its toe or rolling on its arc as the planar geometry says,
/// a body end frictionless on its rounded end. Checks that a planar toe contact is the toe
/// (not the arc's hip end), at the spatial toe's position.
fn spatial_contacts(
    rhex: &Rhex,
    data: &Data,
    p: &RhexSixLegs,
    model: &SpatialModel,
    q: &DVector<f64>,
) -> Vec<PointContact> {
    let mut sdata = SpatialData::new(model);
    sp::kinematics::forward_kinematics(model, &mut sdata, q.as_slice()).unwrap();
    let mut out = Vec::new();
    for (k, geometry) in &data.constraints.geometry {
        let name = &rhex.model.contacts[*k].name;
        let (site, kind) = name.split_once('_').unwrap();
        for side in SIDES {
            let pair_side = format!("{site}_{side}");
            let c = match (kind, geometry.touch) {
                ("body", _) => p.body_end(model, &pair_side).unwrap(),
                ("leg", TouchKind::Rolling) => p.leg_arc(model, &pair_side, true).unwrap(),
                ("leg", TouchKind::Point) => {
                    let c = p.toe(model, &pair_side, true).unwrap();
                    let toe = sp::kinematics::frame_placement(model, &sdata, c.frame).translation;
                    let (xz, _) = rhex::force_to_planar(&toe);
                    let gap = (geometry.point.x - xz[0])
                        .abs()
                        .max((geometry.point.y - xz[1]).abs());
                    assert!(
                        gap < 1e-12,
                        "planar point contact {name} is not the toe: {gap}"
                    );
                    c
                }
                other => panic!("{other:?}"),
            };
            out.push(match kind {
                "leg" => c.in_plane(Vector3::x()).unwrap(),
                _ => c,
            });
        }
    }
    out
}

/// The planar `λ` from the spatial one: each pair's two world forces summed, mapped to NED
/// and projected on the planar rows' directions.
fn planar_forces(
    rhex: &Rhex,
    data: &Data,
    contacts: &[PointContact],
    lam: &DVector<f64>,
) -> DVector<f64> {
    let mut totals = Vec::new();
    let mut row = 0;
    for pair in contacts.chunks(2) {
        let mut f = Vector3::zeros();
        for c in pair {
            for d in &c.directions()[..c.n_rows()] {
                f += d * lam[row];
                row += 1;
            }
        }
        totals.push(f);
    }
    assert_eq!(row, lam.len());
    let mut out = DVector::zeros(data.constraints.rows.len());
    for (r, crow) in data.constraints.rows.iter().enumerate() {
        let i = data
            .constraints
            .geometry
            .iter()
            .position(|(k, _)| *k == crow.contact)
            .unwrap();
        let (xz, lateral) = rhex::force_to_planar(&totals[i]);
        assert!(
            lateral.abs() < 1e-9 * totals[i].norm().max(1.0),
            "lateral force {lateral}"
        );
        let dir = row_direction(&data.constraints.geometry[i].1.plane, crow.direction);
        out[r] = dir.x * xz[0] + dir.y * xz[1];
        let _ = rhex;
    }
    out
}

fn rel(a: &DVector<f64>, b: &DVector<f64>) -> f64 {
    (a - b).amax() / b.amax().max(1.0)
}

/// Every `0`/`1` mode at random states, on a free-flying and on a planar base: where the
/// planar KKT system is regular the spatial robot gives its `q̈` (both legs of a pair alike, no lateral, roll or yaw acceleration),
/// its per-pair `λ` and its plastic impact to 1e-12 relative (to 1e-13 κ_A where the contact
/// rows' condition κ_A exceeds 10: both solvers' round-off grows with it); where the planar system is singular
/// (redundant rows) so is the spatial one's constraint set, which the spatial engine solves
/// on `A`'s row space instead. With massless legs, a leg pair off the ground is the typed
/// Lemma 5.1 error in the spatial engine's `forward_dynamics`, and follows the planar core's
/// prescribed motion (random accelerations, both legs of the pair alike) in
/// `forward_dynamics_prescribed`; its rates keep their values through an impact in both.
#[test]
fn six_legs_in_pairs_are_the_planar_model() {
    let cases = [true, false].map(|massive| [Base::FreeFlyer, Base::Planar].map(|b| (massive, b)));
    for (massive, base) in cases.into_iter().flatten() {
        let rhex = planar(massive);
        let (p, model) = spatial_on(massive, base);
        let nb = base.nb();
        let mut data = Data::new(&rhex.model);
        let mut sdata = SpatialData::new(&model);
        let mut rng = ChaCha8Rng::seed_from_u64(40);
        let (mut w_qdd, mut w_lam, mut w_imp, mut w_sym) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let (mut compared, mut rolling, mut toes, mut free_legs) = (0, 0, 0, 0);
        let mut kappa_max = 0.0f64;
        for _ in 0..6 {
            let q = random_planar_pose(&mut rng);
            let qd: Vec<f64> = (0..6).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let tau: Vec<f64> = (0..3).map(|_| rng.gen_range(-5.0..5.0)).collect();
            let (qs, vs) = base.state(&q, &qd);
            let mut tau_s = vec![0.0; model.nv];
            for pair in 0..3 {
                tau_s[nb + 2 * pair] = 0.5 * tau[pair];
                tau_s[nb + 1 + 2 * pair] = 0.5 * tau[pair];
            }
            for label in rhex.all_labels() {
                let mode = rhex.mode(&label).unwrap();
                // the planar flow of `mode`, with the free joints' accelerations given
                let planar = |data: &mut _, free_qdd: Option<&[f64]>| {
                    forward_dynamics(
                        &rhex.model,
                        data,
                        &FlatGround,
                        mode,
                        &q,
                        &qd,
                        &tau,
                        free_qdd,
                    )
                };
                let Ok(()) = planar(&mut data, None) else {
                    continue;
                };
                let contacts = spatial_contacts(&rhex, &data, &p, &model, &qs);
                let spatial = |sdata: &mut _| {
                    sp::forward_dynamics(
                        &model,
                        sdata,
                        &contacts,
                        qs.as_slice(),
                        vs.as_slice(),
                        &tau_s,
                    )
                };
                let ours = if data.free_joints.is_empty() || massive {
                    spatial(&mut sdata)
                } else {
                    // a massless pair in the air: without its motion, Lemma 5.1's error;
                    // with it, the planar core's prescribed motion (both legs of the pair)
                    let refused = spatial(&mut sdata);
                    assert!(
                        matches!(
                            refused,
                            Err(SpatialError::Core(CoreError::SingularKkt {
                                kind: SingularityKind::UnconstrainedMasslessMotion,
                                ..
                            }))
                        ),
                        "{label}: {refused:?}"
                    );
                    let free_qdd: Vec<f64> = data
                        .free_joints
                        .iter()
                        .map(|_| rng.gen_range(-50.0..50.0))
                        .collect();
                    planar(&mut data, Some(&free_qdd)).unwrap();
                    let free = sp::free_rates(&model, &contacts);
                    let pairs: Vec<usize> = free.iter().map(|k| (k - nb) / 2).collect();
                    let expected: Vec<usize> =
                        data.free_joints.iter().flat_map(|&j| [j, j]).collect();
                    assert_eq!(pairs, expected, "{label}: free rates {free:?}");
                    let spatial_qdd: Vec<f64> = pairs
                        .iter()
                        .map(|pair| {
                            let i = data.free_joints.iter().position(|j| j == pair).unwrap();
                            free_qdd[i]
                        })
                        .collect();
                    free_legs += 1;
                    sp::forward_dynamics_prescribed(
                        &model,
                        &mut sdata,
                        &contacts,
                        &spatial_qdd,
                        qs.as_slice(),
                        vs.as_slice(),
                        &tau_s,
                    )
                };
                ours.unwrap();
                compared += 1;
                for (_, g) in &data.constraints.geometry {
                    match g.touch {
                        TouchKind::Rolling => rolling += 1,
                        TouchKind::Point => toes += 1,
                    }
                }
                // the round-off of two KKT solvers grows with the condition of the contact
                // rows (`κ_A`, the planar factorization's): errors are measured against
                // 1e-12 where κ_A ≤ 10 and 1e-13 κ_A above
                let kappa = (data.kkt.info().constraint_condition / 10.0).max(1.0);
                kappa_max = kappa_max.max(10.0 * kappa);
                let rel = |a: &DVector<f64>, b: &DVector<f64>| rel(a, b) / kappa;
                let (qdd, right) =
                    base.acceleration_to_planar(qs.as_slice(), vs.as_slice(), sdata.qdd.as_slice());
                w_qdd = w_qdd.max(rel(&qdd, &data.qdd));
                for pair in 0..3 {
                    w_sym = w_sym.max((right[pair] - qdd[pair]).abs() / qdd.amax().max(1.0));
                }
                // y, roll, yaw accelerations
                for &i in base.out_of_plane() {
                    w_sym = w_sym.max(sdata.qdd[i].abs() / qdd.amax().max(1.0));
                }
                let lam = planar_forces(&rhex, &data, &contacts, &sdata.lam);
                w_lam = w_lam.max(rel(&lam, &data.lambda));

                let planar_imp =
                    plastic_impact(&rhex.model, &mut data, &FlatGround, mode, &q, &qd).unwrap();
                let imp = sp::impact(&model, &mut sdata, &contacts, qs.as_slice(), vs.as_slice())
                    .unwrap();
                let v_plus = base.velocity_to_planar(qs.as_slice(), imp.v_plus.as_slice());
                let impulse = planar_forces(&rhex, &data, &contacts, &imp.impulse);
                w_imp = w_imp
                    .max(rel(&v_plus, &planar_imp.qd_plus))
                    .max(rel(&impulse, &planar_imp.impulse));
            }
        }
        eprintln!(
            "{base:?}, legs {} kg: {compared} mode-states compared ({toes} toe and {rolling} rolling leg contacts, \
             {free_legs} with a massless pair in the air prescribed); |q̈| {w_qdd:.1e}, |λ| {w_lam:.1e}, \
             |impact| {w_imp:.1e}, |asymmetry| {w_sym:.1e} (each / max(1, κ_A/10); κ_A up to {kappa_max:.0})",
            p.leg_mass_kg
        );
        assert!(compared >= if massive { 60 } else { 3 } && toes > 0 && rolling > 0);
        assert!(massive || free_legs >= 10, "{free_legs}");
        let tol = base.tolerance();
        assert!(w_qdd < tol && w_lam < tol && w_imp < tol && w_sym < tol);
    }
}

/// The Coulomb plastic impact (`μ = 0.4` on every leg, frictionless body ends) of every `0`/`1`
/// mode at random states coming down: each outcome of the planar engine's impact
/// complementarity (`selfmanip::hybrid::coulomb_impact`) that holds every contact is an
/// outcome of the spatial one with each pair's legs in the pair's state (`q̇⁺` and each pair's
/// impulse summed, to 1e-12 relative, 1e-13 κ_A above κ_A = 10), and each spatial outcome whose
/// pairs' legs are alike is one of the planar ones; with lift-off (`Separation::Allowed`) the
/// same holds for every planar outcome, contacts separating included. Sets with both body ends down are left
/// out (four rounded ends on three rates: redundant rows, whose impulse split is least-norm).
#[test]
fn coulomb_impact_of_the_pairs_is_the_planar_one() {
    use selfmanip::hybrid::coulomb_impact::{coulomb_impacts, ContactImpact};
    let mu = 0.4;
    let params = RhexParams {
        pairs: PAIRS.to_vec(),
        mu_front: Some(mu),
        mu_middle: Some(mu),
        mu_rear: Some(mu),
        ..RhexParams::default()
    }
    .with_table_4_2_legs();
    let rhex = Rhex::new(params).unwrap();
    let (p, model) = spatial(true);
    let mut data = Data::new(&rhex.model);
    let mut sdata = SpatialData::new(&model);
    let mut rng = ChaCha8Rng::seed_from_u64(41);
    let (mut worst, mut matched, mut slips, mut symmetric, mut lifted) = (0.0f64, 0, 0, 0, 0);
    for _ in 0..6 {
        let q = random_planar_pose(&mut rng);
        let mut qd: Vec<f64> = (0..6).map(|_| rng.gen_range(-1.0..1.0)).collect();
        qd[4] += 1.5;
        let (qs, vs) = rhex::from_planar(&q, &qd).unwrap();
        for label in rhex.all_labels() {
            let mode = rhex.mode(&label).unwrap();
            let Ok(()) = forward_dynamics(
                &rhex.model,
                &mut data,
                &FlatGround,
                mode,
                &q,
                &qd,
                &[0.0; 3],
                None,
            ) else {
                continue;
            };
            let kappa = (data.kkt.info().constraint_condition / 10.0).max(1.0);
            let geometry = data.constraints.geometry.clone();
            let contacts: Vec<PointContact> = spatial_contacts(&rhex, &data, &p, &model, &qs)
                .into_iter()
                .map(|c| {
                    if c.friction {
                        c.with_impact_friction(mu).unwrap()
                    } else {
                        c
                    }
                })
                .collect();
            let candidates: Vec<usize> = mode.active().collect();
            // both body ends down are four rounded ends on three rates (z, roll, pitch):
            // redundant rows, whose split the spatial impact takes least-norm — left out
            let ends = candidates
                .iter()
                .filter(|&&k| rhex.model.contacts[k].name.ends_with("_body"))
                .count();
            if ends == 2 {
                continue;
            }
            let planar = coulomb_impacts(&rhex.model, &mut data, &FlatGround, &candidates, &q, &qd)
                .unwrap()
                .unwrap();
            let held: Vec<_> = planar
                .iter()
                .filter(|o| o.states.iter().all(|(_, s)| *s != ContactImpact::Separate))
                .collect();
            let Ok(ours) =
                sp::coulomb_impacts(&model, &mut sdata, &contacts, qs.as_slice(), vs.as_slice())
            else {
                continue;
            };
            // (planar q̇⁺, per pair the planar world impulse (x, z)) of a spatial outcome
            let to_planar = |o: &sp::SpatialImpact| {
                let v = rhex::velocity_to_planar(qs.as_slice(), o.v_plus.as_slice());
                let (mut row, mut forces) = (0, Vec::new());
                for pair in contacts.chunks(2) {
                    let mut f = Vector3::zeros();
                    for c in pair {
                        for d in &c.directions()[..c.n_rows()] {
                            f += d * o.impulse[row];
                            row += 1;
                        }
                    }
                    forces.push(rhex::force_to_planar(&f).0);
                }
                (v, forces)
            };
            let gap =
                |o: &sp::SpatialImpact,
                 planar: &selfmanip::hybrid::coulomb_impact::CoulombImpact| {
                    let (v, forces) = to_planar(o);
                    let mut g = rel(&v, &DVector::from_column_slice(&planar.qd_plus));
                    let scale = planar
                        .contact_impulses
                        .iter()
                        .fold(1.0f64, |s, &(_, t, n)| s.max(t.abs()).max(n.abs()));
                    for (&(k, p_t, p_n), f) in planar.contact_impulses.iter().zip(&forces) {
                        let plane = &geometry.iter().find(|(c, _)| *c == k).unwrap().1.plane;
                        let w = row_direction(
                            plane,
                            selfmanip::core::contact::RowDirection::Tangential,
                        ) * p_t
                            + row_direction(plane, selfmanip::core::contact::RowDirection::Normal)
                                * p_n;
                        g = g.max((w.x - f[0]).abs().max((w.y - f[1]).abs()) / scale);
                    }
                    g / kappa
                };
            for o in &held {
                let best = ours.iter().map(|s| gap(s, o)).fold(f64::INFINITY, f64::min);
                worst = worst.max(best);
                matched += 1;
                slips += o
                    .states
                    .iter()
                    .filter(|(_, s)| matches!(s, ContactImpact::Slip { sigma } if *sigma != 0.0))
                    .count();
            }
            let alike = |s: &sp::SpatialImpact| {
                s.states.chunks(2).all(|pair| match (pair[0], pair[1]) {
                    (
                        sp::ImpactState::Slip { direction: a },
                        sp::ImpactState::Slip { direction: b },
                    ) => (a - b).amax() < 1e-9,
                    (a, b) => a == b,
                })
            };
            for s in ours.iter().filter(|s| alike(s)) {
                symmetric += 1;
                let best = held.iter().map(|o| gap(s, o)).fold(f64::INFINITY, f64::min);
                worst = worst.max(best);
            }
            // with lift-off: every planar outcome (contacts separating too), and back
            let free = sp::impact_outcomes(
                &model,
                &mut sdata,
                &contacts,
                qs.as_slice(),
                vs.as_slice(),
                sp::Separation::Allowed,
            )
            .unwrap();
            for o in &planar {
                let best = free.iter().map(|s| gap(s, o)).fold(f64::INFINITY, f64::min);
                worst = worst.max(best);
                lifted += o.states.iter().any(|(_, s)| *s == ContactImpact::Separate) as usize;
            }
            for s in free.iter().filter(|s| alike(s)) {
                let best = planar
                    .iter()
                    .map(|o| gap(s, o))
                    .fold(f64::INFINITY, f64::min);
                worst = worst.max(best);
            }
        }
    }
    eprintln!(
        "Coulomb impact: {matched} planar outcomes holding every contact ({slips} legs slipping), \
         {symmetric} spatial outcomes with pairs alike, {lifted} planar outcomes lifting a \
         contact; worst gap {worst:.1e} (/ max(1, κ_A/10))"
    );
    assert!(
        matched >= 20 && slips >= 5 && symmetric >= matched && lifted >= 5,
        "{matched} {slips} {symmetric} {lifted}"
    );
    assert!(worst < 1e-12, "{worst}");
}

/// A random planar RHex pose `q = [θ₁, θ₂, θ₃, x, z, φ]`: leg angles in ±1.3 rad, x in ±1 m,
/// z in −0.4 … −0.1 m, φ in ±0.3 rad (the states both tests compare the routes at).
fn random_planar_pose(rng: &mut ChaCha8Rng) -> [f64; 6] {
    let mut q = [0.0; 6];
    for t in q.iter_mut().take(3) {
        *t = rng.gen_range(-1.3..1.3);
    }
    q[3] = rng.gen_range(-1.0..1.0);
    q[4] = rng.gen_range(-0.4..-0.1);
    q[5] = rng.gen_range(-0.3..0.3);
    q
}
