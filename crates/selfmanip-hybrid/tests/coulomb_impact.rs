//! The plastic impact with Coulomb friction at every contact (`selfmanip_hybrid::
//! coulomb_impact`), by routes outside it.
//!
//! A uniform bar (mass `m`, half-length `l`, `I = m l²/3`, `q = (x, z, φ)`, z down) lies on
//! level ground on its two ends `(∓l, 0)` and hits it flat, `q̇⁻ = (u, w, 0)`, `w > 0`
//! (falling). By symmetry the two normal impulses are equal and the tangential ones act
//! at the centre's height, so the bar cannot turn; momentum, by hand:
//!
//! ```text
//! normal:      m (ż⁺ − w) = Σ F_z,   ż⁺ = 0 (plastic)      ⇒ each end pushes m w / 2
//! tangential:  m (ẋ⁺ − u) = Σ F_x,   |Σ F_x| ≤ μ m w
//!   u ≤ μ w: the ends stop, ẋ⁺ = 0, T⁺ = 0                          (stick)
//!   u > μ w: they slip on the cone edge, ẋ⁺ = u − μ w,
//!            T⁻ − T⁺ = ½ m (u² + w²) − ½ m (u − μ w)²                (slip)
//! ```
//!
//! World impulses on the robot from the rows (`docs/conventions.md`): a pushing normal
//! impulse is negative; a row `r` of direction `d_r` (`selfmanip_core::contact::
//! row_direction`: `n̂` into the ground, `t̂ = S(n̂)`) is `A_r = −d_rᵀ J` and the impact
//! `M̄ Δq̇ = −Aᵀ P`, so the world impulse of contact `k` is `F = P_t t̂ + P_n n̂`.
use selfmanip_core::contact::ContactKind;
use selfmanip_core::{ContactMode, Data, GroundPlane, Model};
use selfmanip_hybrid::coulomb_impact::{coulomb_impacts, ContactImpact, CoulombImpact, NotOffered};
use selfmanip_hybrid::event::PainleveReason;
use selfmanip_hybrid::flow::{Flow, FlowWorkspace};
use selfmanip_hybrid::jam::coulomb_jam;
use selfmanip_hybrid::reset::Reset;
use selfmanip_hybrid::{EventKind, HybridOptions, ZeroTorque};
use std::sync::Arc;

mod systems;
use systems::{Friction, Lcg, G};

const M: f64 = 2.0;
const L: f64 = 0.3;

fn inertia() -> f64 {
    M * L * L / 3.0
}

fn bar(mu: f64) -> Model {
    systems::body(
        M,
        inertia(),
        G,
        &[
            ("left", -L, 0.0, Friction::Coulomb(mu)),
            ("right", L, 0.0, Friction::Coulomb(mu)),
        ],
    )
}

/// Kinetic energy by hand.
fn kinetic(qd: &[f64]) -> f64 {
    0.5 * M * (qd[0] * qd[0] + qd[1] * qd[1]) + 0.5 * inertia() * qd[2] * qd[2]
}

/// The world velocity `(ẋ, ż)` of end `k` (`0` left at `−l`, `1` right at `+l`) of the level
/// bar, by hand: a point at offset `r` moves at `v + φ̇ (r_z, −r_x)` (tests/systems).
fn end_velocity(qd: &[f64], k: usize) -> (f64, f64) {
    let rx = if k == 0 { -L } else { L };
    (qd[0], qd[1] - qd[2] * rx)
}

/// The world impulse on the bar of each contact, `(contact, F_x, F_z)`, from the outcome's
/// impulses in the rows' convention: `F = P_t t̂ + P_n n̂` (module docs).
fn world_impulses(o: &CoulombImpact) -> Vec<(usize, f64, f64)> {
    let plane = GroundPlane::level(0.0);
    let (n, t) = (plane.normal(), plane.tangent());
    o.contact_impulses
        .iter()
        .map(|&(k, pt, pn)| (k, pt * t.x + pn * n.x, pt * t.y + pn * n.y))
        .collect()
}

/// The tangential row's velocity of a point moving at `ẋ` on level ground: `A_t q̇ = −t̂ · v`
/// (module docs), the velocity whose sign a slip's `σ` is.
fn row_vt(vx: f64) -> f64 {
    -GroundPlane::level(0.0).tangent().x * vx
}

fn impacts(model: &Model, qd: &[f64]) -> Vec<CoulombImpact> {
    let mut data = Data::new(model);
    coulomb_impacts(
        model,
        &mut data,
        &GroundPlane::level(0.0),
        &[0, 1],
        &[0.0, 0.0, 0.0],
        qd,
    )
    .unwrap()
    .unwrap()
}

/// The bar landing flat: one outcome, the closed form's — sticking for `u ≤ μ w` (all the
/// energy lost), slipping at `u − μ w` above; each end pushes `m w / 2`, the tangential
/// impulses sum to `m Δẋ` and lie on (slip) or in (stick) the cone, and the ends' velocities
/// after, by hand, are what the states say.
#[test]
fn bar_landing_flat_sticks_or_slips_by_the_closed_form() {
    let (w, mu) = (0.5, 0.4);
    for u in [0.05, 0.15, 0.25, 1.0, -1.0] {
        let model = bar(mu);
        let qd = [u, w, 0.0];
        let out = impacts(&model, &qd);
        assert_eq!(out.len(), 1, "u {u}: {out:?}");
        let o = &out[0];
        let slip = u.abs() > mu * w;
        let x_after = if slip { u - mu * w * u.signum() } else { 0.0 };
        let want = [x_after, 0.0, 0.0];
        for (a, b) in o.qd_plus.iter().zip(want) {
            assert!((a - b).abs() < 1e-12, "u {u}: {:?} vs {want:?}", o.qd_plus);
        }
        let lost = kinetic(&qd) - kinetic(&o.qd_plus);
        let want_lost = 0.5 * M * (u * u + w * w) - 0.5 * M * x_after * x_after;
        assert!(
            (lost - want_lost).abs() < 1e-12,
            "u {u}: {lost} vs {want_lost}"
        );
        assert!((o.kinetic_change + lost).abs() < 1e-12);
        // each end pushes m w / 2 (up: negative z), the tangential ones sum to m Δẋ
        let f = world_impulses(o);
        assert_eq!(f.len(), 2);
        let fx: f64 = f.iter().map(|e| e.1).sum();
        assert!((fx - M * (x_after - u)).abs() < 1e-12, "u {u}: {f:?}");
        for &(k, fx_k, fz_k) in &f {
            assert!((fz_k + M * w / 2.0).abs() < 1e-12, "u {u} end {k}: {f:?}");
            assert!(fx_k.abs() <= mu * -fz_k * (1.0 + 1e-12), "u {u}: {f:?}");
            if slip {
                // on the cone's edge, opposing the motion
                assert!((fx_k.abs() - mu * -fz_k).abs() < 1e-12);
                assert!(fx_k * u < 0.0);
            }
        }
        // the states, against the ends' velocities by hand
        for &(k, st) in &o.states {
            let (vx, vz) = end_velocity(&o.qd_plus, k);
            assert!(vz.abs() < 1e-12, "u {u}: end {k} {st:?}");
            match st {
                ContactImpact::Separate => panic!("u {u}: end {k} separates"),
                ContactImpact::Stick => assert!(vx.abs() < 1e-12),
                ContactImpact::Slip { sigma } => assert!(sigma * row_vt(vx) >= -1e-12),
            }
        }
        assert!(!o.mode.is_flight());
    }
}

/// Over 2,000 states of the bar (ends on the ground, any velocity and spin, any μ), every
/// solution of the impact problem: never adds kinetic energy (by hand from `q̇⁺`); every
/// complementarity condition holds on the ends' velocities computed by hand and the world
/// impulses from the rows — a separating end neither pushes nor approaches, a held end
/// pushes and does not move along the normal, a sticking end stands still inside its cone,
/// a slipping end's impulse is on the cone's edge opposing its motion — and the impulses
/// balance the momentum (`m Δv = Σ F`, `I Δφ̇ = Σ r × F`). Every state has a solution
/// (existence of the plastic frictional impact, Anitescu & Potra 1997).
#[test]
fn every_solution_dissipates_and_satisfies_complementarity_by_hand() {
    let mut rng = Lcg(16);
    let mut solved = 0;
    for _ in 0..2000 {
        let mu = rng.uniform(0.0, 2.0);
        let qd = [
            rng.uniform(-2.0, 2.0),
            rng.uniform(-1.0, 2.0),
            rng.uniform(-10.0, 10.0),
        ];
        let model = bar(mu);
        let out = impacts(&model, &qd);
        if !out.is_empty() {
            solved += 1;
        }
        for o in &out {
            let ctx = format!("μ {mu} q̇⁻ {qd:?}: {o:?}");
            assert!(
                kinetic(&o.qd_plus) <= kinetic(&qd) * (1.0 + 1e-12) + 1e-12,
                "{ctx}"
            );
            let f = world_impulses(o);
            let force = |k: usize| {
                f.iter()
                    .find(|e| e.0 == k)
                    .map_or((0.0, 0.0), |e| (e.1, e.2))
            };
            let tol = 1e-9 * (1.0 + qd.iter().fold(0.0f64, |a, b| a.max(b.abs())));
            for &(k, st) in &o.states {
                let (vx, vz) = end_velocity(&o.qd_plus, k);
                let (fx, fz) = force(k);
                let push = -fz;
                match st {
                    ContactImpact::Separate => {
                        assert!(vz <= tol, "{ctx}");
                        assert!(fx == 0.0 && fz == 0.0, "{ctx}");
                    }
                    ContactImpact::Stick => {
                        assert!(vz.abs() <= tol && vx.abs() <= tol, "{ctx}");
                        assert!(push >= -tol && fx.abs() <= mu * push + tol, "{ctx}");
                    }
                    ContactImpact::Slip { sigma } => {
                        assert!(vz.abs() <= tol && sigma * row_vt(vx) >= -tol, "{ctx}");
                        assert!(push >= -tol, "{ctx}");
                        assert!((fx.abs() - mu * push).abs() <= tol, "{ctx}");
                        assert!(fx * vx <= tol, "{ctx}");
                    }
                }
            }
            // momentum: m Δv = Σ F, I Δφ̇ = Σ (r_z F_x − r_x F_z) (tests/systems' moment)
            let (sx, sz) = f.iter().fold((0.0, 0.0), |a, e| (a.0 + e.1, a.1 + e.2));
            let moment: f64 = f
                .iter()
                .map(|&(k, _, fz)| -(if k == 0 { -L } else { L }) * fz)
                .sum();
            assert!((M * (o.qd_plus[0] - qd[0]) - sx).abs() <= tol, "{ctx}");
            assert!((M * (o.qd_plus[1] - qd[1]) - sz).abs() <= tol, "{ctx}");
            assert!(
                (inertia() * (o.qd_plus[2] - qd[2]) - moment).abs() <= tol,
                "{ctx}"
            );
        }
    }
    assert_eq!(solved, 2000);
}

/// The resolution of a Painlevé jam (outside the cone) of contact 0 sliding at `(q, q̇)` at
/// `t = 0`, with no torque and the default options.
fn jam_of_sliding_contact_0(
    model: &Model,
    ground: &GroundPlane,
    q: &[f64],
    qd: &[f64],
) -> Result<Reset, PainleveReason> {
    let mut flow = Flow::new(model, ground, Arc::new(ZeroTorque));
    let mut ws = FlowWorkspace::new(model);
    let y: Vec<f64> = q.iter().chain(qd).copied().collect();
    coulomb_jam(
        &mut ws,
        &mut flow,
        &HybridOptions::default(),
        ContactMode::FLIGHT.with(0, ContactKind::Slide),
        (&[], 0),
        (0.0, &y),
        PainleveReason::JamOutsideCone,
    )
    .unwrap()
}

/// A contact on a massless leg has no impulse response (thesis 5.1.3): the problem is not
/// set up, and the resolution of a Painlevé end built on it hands back the reason it was
/// given — the end stays typed.
#[test]
fn massless_leg_is_not_offered_and_the_end_stays_typed() {
    let model = systems::one_leg(0.2, 0.0, G);
    let nq = model.nq();
    let mut data = Data::new(&model);
    // the toe on the ground below the hip (q = [θ, x, z, φ], z down)
    let q = vec![0.0, 0.0, -0.2, 0.0];
    let qd = vec![0.0, 0.3, 0.0, 0.0];
    assert_eq!(nq, 4);
    let r = coulomb_impacts(&model, &mut data, &GroundPlane::level(0.0), &[0], &q, &qd).unwrap();
    assert_eq!(r, Err(NotOffered::Massless));
    let ground = GroundPlane::level(0.0);
    let out = jam_of_sliding_contact_0(&model, &ground, &q, &qd);
    assert_eq!(out.map(|_| ()), Err(PainleveReason::JamOutsideCone));
}

/// Painlevé's rod (tests/painleve_jam.rs: `θ = 0.8`, end sliding away from the centre at
/// `v = −0.3`, `μ = 1.05 μ*`): the velocity-level problem has two solutions — the slide
/// going on untouched (`p = 0`, the end already at zero normal velocity) and the stick with
/// the closed-form impulse `P = −(m v/4)(1 + 3c², −3sc)` — which is why the impact alone
/// cannot choose; the force check after it can: the slide is inconsistent (the Painlevé
/// end itself), so [`coulomb_jam`] keeps the stick, the same reset as the stick jam
/// (`selfmanip_hybrid::jam`), a second formulation of it.
#[test]
fn painleve_rod_has_two_velocity_solutions_and_the_force_check_keeps_the_jam() {
    let (m, l, theta, v) = (1.5, 0.4, 0.8_f64, -0.3);
    let (s, c) = theta.sin_cos();
    let mu = 1.05 * (1.0 + 3.0 * c * c) / (3.0 * s * c);
    let model = systems::body(
        m,
        m * l * l / 3.0,
        G,
        &[("end", -l, 0.0, Friction::Coulomb(mu))],
    );
    let ground = GroundPlane::level(0.0);
    let q = [0.0, -l * s, theta];
    let qd = [v, 0.0, 0.0];
    let mut data = Data::new(&model);
    let out = coulomb_impacts(&model, &mut data, &ground, &[0], &q, &qd)
        .unwrap()
        .unwrap();
    assert_eq!(out.len(), 2, "{out:?}");
    let want = [
        -(m * v / 4.0) * (1.0 + 3.0 * c * c),
        (m * v / 4.0) * 3.0 * s * c,
    ];
    let untouched = out
        .iter()
        .find(|o| o.qd_plus == qd)
        .expect("the slide going on");
    assert!(matches!(
        untouched.states[..],
        [(0, ContactImpact::Slip { .. })]
    ));
    let stuck = out
        .iter()
        .find(|o| o.states[..] == [(0, ContactImpact::Stick)])
        .expect("the stick");
    let (_, pt, pn) = stuck.contact_impulses[0];
    assert!(
        (pt - want[0]).abs() < 1e-12 && (pn - want[1]).abs() < 1e-12,
        "{stuck:?}"
    );
    // the resolution of the Painlevé end keeps the stick alone
    let r = jam_of_sliding_contact_0(&model, &ground, &q, &qd);
    let Ok(Reset::Continue { event, .. }) = r else {
        panic!("{r:?}");
    };
    assert_eq!(event.kind, EventKind::Jam);
    assert_eq!(
        event.mode_after,
        ContactMode::FLIGHT.with(0, ContactKind::Stick)
    );
    for (got, w) in event.impulse.iter().zip(want) {
        assert!((got - w).abs() < 1e-12, "{:?} vs {want:?}", event.impulse);
    }
    let lost = event.kinetic_before - event.kinetic_after;
    assert!((lost - m * v * v * (1.0 + 3.0 * c * c) / 8.0).abs() < 1e-12);
}

/// Ends that never slip (`μ = ∞`): the bar landing flat stops dead whatever its speed
/// along the ground (the closed form's stick with an unbounded cone), all its energy lost.
#[test]
fn bar_on_ends_that_never_slip_stops_dead() {
    let model = systems::body(
        M,
        inertia(),
        G,
        &[
            ("left", -L, 0.0, Friction::Stick(None)),
            ("right", L, 0.0, Friction::Stick(None)),
        ],
    );
    for u in [0.05, 3.0, -7.0] {
        let out = impacts(&model, &[u, 0.5, 0.0]);
        assert_eq!(out.len(), 1, "{out:?}");
        assert!(out[0].qd_plus.iter().all(|v| v.abs() < 1e-12), "{out:?}");
        assert!((out[0].kinetic_change + kinetic(&[u, 0.5, 0.0])).abs() < 1e-12);
    }
}
