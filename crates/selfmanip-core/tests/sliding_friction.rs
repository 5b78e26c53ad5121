//! Coulomb sliding friction at sites that no massless leg's statics resolve (a body end, a
//! massive leg): the folded nonsymmetric KKT system of `selfmanip_core::friction` ("The
//! general sliding site", thesis (5.2) with `f^fr = −Bᵀλ`) against closed forms derived by
//! hand — a block sliding on level ground (deceleration `μ g`, normal forces from the moment
//! balance), a puck on an incline (`g (sin α ∓ μ cos α)`), Painlevé's rod (the consistency
//! threshold `μ = (1 + 3cos²θ)/(3 sinθ cosθ)` and its accelerations) — and the massless-leg
//! limit: a leg of vanishing mass through the fold tends to the same leg without mass through
//! its statics (a second formulation, thesis (5.3)–(5.4) with the leg's row).
//!
//! Frames (docs/conventions.md): NED, z down, `q = [θ…, x, z, φ]`, a body point `p` at
//! `X + R(φ) p`, `R(φ) = [[cos φ, sin φ], [−sin φ, cos φ]]`; `λ` is the ground's force on the
//! robot, pushing normals negative.
mod common;

use common::{coulomb_body, one_leg_body, slide_on_flat, sliding, test_robot, G};
use selfmanip_core::description::{FrictionDescription, SpringDescription};
use selfmanip_core::friction::SlideDirection;
use selfmanip_core::{
    forward_dynamics, CoreError, Data, FlatGround, GroundPlane, Model, RowDirection,
    SingularityKind,
};

/// The normal multiplier of contact `k` after a solve.
fn lambda_n(data: &Data, k: usize) -> f64 {
    let r = data
        .constraints
        .rows
        .iter()
        .position(|r| r.contact == k && r.direction == RowDirection::Normal)
        .unwrap();
    data.lambda[r]
}

/// A `w × h` block on its two bottom corners, sliding at `v` along `+x` or `−x`: no pitch or
/// heave, `ẍ = −μ g sign v`, and the moment of the two friction forces (below the centre of
/// mass by `h/2`) shifts the load to the leading corner: `N₂ − N₁ = μ h m g / w sign v`
/// (contact 2 at `+w/2`), `N₁ + N₂ = m g`.
#[test]
fn block_sliding_on_level_ground_decelerates_at_mu_g_and_loads_its_leading_corner() {
    let (w, h, m, mu) = (0.1, 0.05, 2.0, 0.3);
    let model = coulomb_body(
        m,
        m * (w * w + h * h) / 12.0,
        &[("left", -w / 2.0, h / 2.0), ("right", w / 2.0, h / 2.0)],
        mu,
        mu,
    );
    let mut data = Data::new(&model);
    for v in [0.7, -0.4] {
        let q = [0.3, -h / 2.0, 0.0];
        let qd = [v, 0.0, 0.0];
        slide_on_flat(&model, &mut data, &[0, 1], &q, &qd, &[]).unwrap();
        let s = f64::signum(v);
        assert!((data.qdd[0] + mu * G * s).abs() < 1e-12, "{}", data.qdd);
        assert!(data.qdd[1].abs() < 1e-12 && data.qdd[2].abs() < 1e-12);
        let dn = mu * h * m * G / w * s;
        let (n1, n2) = ((m * G - dn) / 2.0, (m * G + dn) / 2.0);
        assert!(
            (lambda_n(&data, 0) + n1).abs() < 1e-10,
            "{}",
            lambda_n(&data, 0)
        );
        assert!(
            (lambda_n(&data, 1) + n2).abs() < 1e-10,
            "{}",
            lambda_n(&data, 1)
        );
        // the generalized friction force is the two corners' μN, against the motion
        assert!((data.friction[0] + mu * m * G * s).abs() < 1e-10);
        // each site reports its tangential force, μ σ λ_n
        for site in &data.sliding {
            assert!(site.general && site.sigma == s);
            assert!((site.force_t - mu * s * lambda_n(&data, site.contact)).abs() < 1e-12);
        }
    }
}

/// A puck (its foot at its centre of mass) on a plane tilted by `α`: sliding downhill it
/// accelerates at `g (sin α − μ cos α)` (decelerates when `μ > tan α`), uphill it
/// decelerates at `g (sin α + μ cos α)` (friction and gravity both downhill); the normal
/// force is `m g cos α` either way.
#[test]
fn puck_on_incline_slides_with_g_sin_alpha_minus_or_plus_mu_g_cos_alpha() {
    let (m, mu) = (2.0, 0.4);
    let model = coulomb_body(m, 0.01, &[("foot", 0.0, 0.0)], mu, mu);
    let mut data = Data::new(&model);
    for alpha in [0.2_f64, 0.6] {
        let plane = GroundPlane {
            point_m: [0.0, 0.0],
            normal_into_ground: [alpha.sin(), alpha.cos()],
        };
        let t = plane.tangent();
        // downhill: gravity's component along t
        let down = if t.y > 0.0 { t } else { -t };
        for (dir, expected) in [
            (1.0, G * (alpha.sin() - mu * alpha.cos())),
            (-1.0, G * (alpha.sin() + mu * alpha.cos())),
        ] {
            let v = 0.5 * dir * down;
            let q = [0.0, 0.0, alpha];
            let qd = [v.x, v.y, 0.0];
            forward_dynamics(&model, &mut data, &plane, sliding(&[0]), &q, &qd, &[], None).unwrap();
            let a = data.qdd[0] * down.x + data.qdd[1] * down.y;
            assert!((a - expected).abs() < 1e-12, "α {alpha}: {a} vs {expected}");
            let a_n = data.qdd[0] * plane.normal().x + data.qdd[1] * plane.normal().y;
            assert!(a_n.abs() < 1e-12 && data.qdd[2].abs() < 1e-12);
            assert!((lambda_n(&data, 0) + m * G * alpha.cos()).abs() < 1e-10);
        }
    }
}

/// Painlevé's rod, derived by hand: a uniform rod (mass `m`, half-length `l`, `I = m l²/3`)
/// whose end `P = X + l(−cos θ, sin θ)` slides on level ground (the centre of mass above and
/// ahead of it, `0 < θ < π/2`). With the ground's push `N ≥ 0` and Coulomb friction
/// `F_x = −μ σ N` (`σ = sign ẋ_P`): `m ẍ = F_x`, `m z̈ = m g − N`,
/// `I φ̈ = l sinθ F_x − l cosθ N`, and the contact `z̈ + l cosθ φ̈ − l sinθ φ̇² = 0` give
/// `N (1 + 3cos θ (cos θ + μ σ sin θ)) / m = g − l sin θ φ̇²`. The factor is the normal
/// response `W`: for `σ = −1` (the end sliding away from the centre) it is negative iff
/// `μ > (1 + 3cos²θ)/(3 sinθ cosθ)` — there a push would draw the end into the ground
/// (Painlevé's paradox), and the engine must say so; below, its accelerations are these.
#[test]
fn painleve_rod_is_inconsistent_exactly_beyond_the_closed_form_threshold() {
    let (m, l) = (1.5, 0.4);
    for theta in [0.35_f64, 0.8, 1.1] {
        let (s, c) = theta.sin_cos();
        let mu_star = (1.0 + 3.0 * c * c) / (3.0 * s * c);
        assert!(mu_star >= 4.0 / 3.0 - 1e-12);
        for (factor, sigma) in [(0.97, -1.0), (1.03, -1.0), (1.03, 1.0), (0.5, -1.0)] {
            let mu = mu_star * factor;
            let model = coulomb_body(m, m * l * l / 3.0, &[("end", -l, 0.0)], mu, mu);
            let mut data = Data::new(&model);
            // the end on the ground, sliding at σ·0.3 m/s, turning at φ̇
            let phidot = 0.7;
            let q = [0.0, -l * s, theta];
            // ẋ_P = ẋ + φ̇ l sinθ, ż_P = ż + φ̇ l cosθ = 0
            let xd = sigma * 0.3 - phidot * l * s;
            let qd = [xd, -phidot * l * c, phidot];
            let r = slide_on_flat(&model, &mut data, &[0], &q, &qd, &[]);
            let w = 1.0 + 3.0 * c * (c + mu * sigma * s);
            if w < 0.0 {
                match r {
                    Err(CoreError::PainleveInconsistent { contact, .. }) => {
                        assert_eq!(contact, "end")
                    }
                    other => panic!("θ {theta}, μ {mu}, σ {sigma}: {other:?}"),
                }
                continue;
            }
            r.unwrap_or_else(|e| panic!("θ {theta}, μ {mu}, σ {sigma}: {e}"));
            let n = m * (G - l * s * phidot * phidot) / w;
            let fx = -mu * sigma * n;
            let (xdd, zdd, phidd) = (
                fx / m,
                G - n / m,
                (l * s * fx - l * c * n) / (m * l * l / 3.0),
            );
            for (got, want) in [(data.qdd[0], xdd), (data.qdd[1], zdd), (data.qdd[2], phidd)] {
                assert!(
                    (got - want).abs() < 1e-9 * (1.0 + want.abs()),
                    "{got} vs {want}"
                );
            }
            assert!((lambda_n(&data, 0) + n).abs() < 1e-9 * n.abs().max(1.0));
        }
    }
}

/// A body on one leg (`one link`, its hip at the body's centre) whose toe slides with
/// Coulomb friction, the body's belly clear of the ground.
fn legged(link_mass: f64, mu_k: f64) -> Model {
    let (len, inertia) = (0.17, link_mass * 0.17 * 0.17 / 12.0);
    let text = format!(
        r#"
[[legs.links]]
length_m = {len}
mass_kg = {link_mass}
inertia_kg_m2 = {inertia}
com_m = [0.0, {com}]
[[contacts]]
name = "toe"
leg = "leg"
shape = {{ kind = "point", position_m = [0.0, {len}] }}
friction = {{ kind = "sticking", mu = {mu_k}, mu_kinetic = {mu_k} }}
"#,
        com = len / 2.0
    );
    one_leg_body("one leg", 0.05, &text)
}

/// Sets the hip rate `θ̇` (`qd[0]`) so that the toe's normal velocity vanishes (the row
/// `A_n q̇ = 0` of contact 0 sliding), the body's rates kept.
fn keep_toe_on_ground(model: &Model, q: &[f64], qd: &mut [f64]) {
    let mut dp = Data::new(model);
    dp.prepare_geometry(model, &FlatGround, sliding(&[0]), q, qd)
        .unwrap();
    let a = &dp.constraints.a;
    let rhs: f64 = (1..4).map(|k| a[(0, k)] * qd[k]).sum();
    qd[0] = -rhs / a[(0, 0)];
}

/// The toe's pose: leg angle `θ`, body pitch `φ`, the toe on the ground at `x = 0`.
fn on_toe(model: &Model, theta: f64, phi: f64) -> Vec<f64> {
    let mut q = vec![theta, 0.0, 0.0, phi];
    let p =
        selfmanip_core::contact_points(model, &FlatGround, &q, &[0.0; 4]).unwrap()[0].position_m;
    q[1] -= p[0];
    q[2] -= p[1];
    q
}

/// The massless limit: a massive leg's toe goes through the folded system, a massless one
/// through its leg's statics (the formula `λ_n = f_j / ((A_n)_j + μσ(A_t)_j)`); as the leg's
/// mass and inertia vanish (`m_l = 10⁻⁴ … 10⁻⁷` kg) the folded accelerations and forces
/// approach the statics ones at the rate of the mass (first order), whatever the torque.
/// The legs lean by more than the cone's half-angle (`tan|θ| > μ`) so that neither sliding
/// direction is a Painlevé case (next test).
#[test]
fn massive_leg_toe_tends_to_the_massless_statics_as_the_leg_mass_vanishes() {
    let massless = legged(0.0, 0.5);
    let mut d0 = Data::new(&massless);
    for (theta, phi, tau) in [(0.7, 0.1, 1.5), (-0.8, -0.1, -0.8), (0.9, 0.05, 0.6)] {
        let q = on_toe(&massless, theta, phi);
        // the body moving so that the toe slides at −0.2 m/s and stays on the ground
        let qd_body = [0.4, -0.1, 0.3];
        let mut qd = vec![0.0, qd_body[0], qd_body[1], qd_body[2]];
        keep_toe_on_ground(&massless, &q, &mut qd);
        slide_on_flat(&massless, &mut d0, &[0], &q, &qd, &[tau]).unwrap();
        assert!(!d0.sliding[0].general && d0.sliding[0].sigma != 0.0);
        let mut errs = vec![];
        for m_l in [1e-4, 1e-5, 1e-6, 1e-7] {
            let massive = legged(m_l, 0.5);
            let mut d1 = Data::new(&massive);
            slide_on_flat(&massive, &mut d1, &[0], &q, &qd, &[tau]).unwrap();
            assert!(d1.sliding[0].general);
            assert_eq!(d1.sliding[0].sigma, d0.sliding[0].sigma);
            let e = (0..4)
                .map(|k| (d1.qdd[k] - d0.qdd[k]).abs() / (1.0 + d0.qdd[k].abs()))
                .fold(0.0, f64::max)
                .max((d1.lambda[0] - d0.lambda[0]).abs() / d0.lambda[0].abs());
            errs.push(e);
        }
        for pair in errs.windows(2) {
            // first order: each decade of mass a decade of error (within round-off)
            assert!(pair[1] < 0.2 * pair[0] || pair[1] < 1e-8, "{errs:?}");
        }
        assert!(errs[3] < 1e-4, "{errs:?}");
    }
}

/// A body site with kinetic friction is accepted by the description; a two-joint massless
/// leg's sliding toe leaves the leg's second joint unpinned (two torques, one force): a
/// typed singular-KKT error (Lemma 5.1), with or without friction, never a number.
#[test]
fn two_joint_massless_leg_sliding_is_a_typed_singularity() {
    // the shared massless two-link leg, its knee sprung, its foot sticking with mu = 0.5 and
    // sliding with mu_k = 0.5
    let mut robot = test_robot("massless_two_link_leg.toml");
    robot.legs[0].links[1].spring = Some(SpringDescription {
        stiffness_n_m_per_rad: 5.0,
        cubic_stiffness_n_m_per_rad3: 0.0,
        damping_n_m_s_per_rad: 0.0,
        rest_angle_rad: 0.0,
    });
    robot.contacts[0].friction = FrictionDescription::Sticking {
        mu: Some(0.5),
        mu_kinetic: Some(0.5),
    };
    let model = robot.build().unwrap();
    let mut data = Data::new(&model);
    let mut q = vec![0.3, 0.4, 0.0, 0.0, 0.0];
    let p =
        selfmanip_core::contact_points(&model, &FlatGround, &q, &[0.0; 5]).unwrap()[0].position_m;
    q[3] -= p[1];
    let qd = vec![0.0, 0.0, 0.2, 0.0, 0.0];
    let r = slide_on_flat(&model, &mut data, &[0], &q, &qd, &[0.5, 0.0]);
    assert!(
        matches!(
            r,
            Err(CoreError::SingularKkt {
                kind: SingularityKind::UnconstrainedMasslessMotion,
                ..
            })
        ),
        "{r:?}"
    );
}

/// `forward_dynamics` of a legless body at rest, pitched by `alpha` to lie on the plane
/// through the origin inclined by `alpha`, its contact 0 sliding, into `data`; the plane.
fn puck_at_rest_on_incline(model: &Model, data: &mut Data, alpha: f64) -> GroundPlane {
    let plane = GroundPlane {
        point_m: [0.0, 0.0],
        normal_into_ground: [alpha.sin(), alpha.cos()],
    };
    let (q, qd) = ([0.0, 0.0, alpha], [0.0; 3]);
    forward_dynamics(model, data, &plane, sliding(&[0]), &q, &qd, &[], None).unwrap();
    plane
}

/// A site at rest whose sticking force the cone cannot hold takes the cone edge on the side
/// of that force and starts sliding against it (`σ v̇_t ≥ 0`): a puck at rest on an incline
/// steeper than its cone (`tan α > μ`) slides downhill at `g (sin α − μ cos α)` (the
/// `FromRest` law of `selfmanip_core::friction`, now at a body site).
#[test]
fn puck_at_rest_on_a_steep_incline_takes_the_downhill_edge() {
    let (m, mu, alpha) = (2.0, 0.3, 0.5_f64);
    let model = coulomb_body(m, 0.01, &[("foot", 0.0, 0.0)], mu, mu);
    let mut data = Data::new(&model);
    data.set_slide_directions(&[(0, SlideDirection::FromRest)]);
    let t = puck_at_rest_on_incline(&model, &mut data, alpha).tangent();
    let down = if t.y > 0.0 { t } else { -t };
    let a = data.qdd[0] * down.x + data.qdd[1] * down.y;
    assert!(
        (a - G * (alpha.sin() - mu * alpha.cos())).abs() < 1e-12,
        "{a}"
    );
    let s = &data.sliding[0];
    assert!(s.general && s.sigma != 0.0 && !s.cone_holds);
    // and on a shallower incline the cone holds it: no edge (the caller must let it stick)
    puck_at_rest_on_incline(&model, &mut data, 0.2);
    assert!(data.sliding[0].cone_holds);
}

/// Painlevé's paradox on a light leg: with the leg's inertia dominating, the leg turns about
/// its hip as a rod pinned there, leaning by `θ` from the vertical; the ground's push `N` has
/// the lever `L sin θ` about the hip and the friction `μN` the lever `L cos θ`, so the toe's
/// normal acceleration per push goes as `sin θ (sin θ ∓ μ cos θ)` — negative for the toe
/// dragged one way iff `μ > tan θ`. So with `tan θ < μ` exactly one of the two sliding
/// directions is inconsistent (typed error), with `tan θ > μ` neither is.
#[test]
fn light_leg_dragged_with_mu_above_tan_theta_is_a_painleve_case() {
    let model = legged(1e-5, 0.5);
    for (theta, expect_bad) in [(0.25, 1), (-0.3, 1), (0.7, 0), (-0.8, 0)] {
        let q = on_toe(&model, theta, 0.0);
        let mut bad = 0;
        for v in [0.2, -0.2] {
            let mut qd = vec![0.0, v, 0.0, 0.0];
            keep_toe_on_ground(&model, &q, &mut qd);
            let mut data = Data::new(&model);
            match slide_on_flat(&model, &mut data, &[0], &q, &qd, &[0.3]) {
                Err(CoreError::PainleveInconsistent { contact, .. }) => {
                    assert_eq!(contact, "toe");
                    bad += 1;
                }
                r => r.unwrap(),
            }
        }
        assert_eq!(bad, expect_bad, "θ {theta}");
    }
}

/// At Painlevé's threshold itself, `μ = μ*(θ)`, the rod's normal response vanishes: the
/// folded system `[M̄ (A+B)ᵀ; A 0]` is singular (its `I − Y` is `W/W₀ = 0`) and `N` would be
/// infinite; a hair beyond the threshold the mode is inconsistent. Both are typed errors,
/// never a number.
#[test]
fn painleve_threshold_itself_is_a_typed_singularity_not_a_number() {
    let (m, l, theta) = (1.5, 0.4, 0.8_f64);
    let (s, c) = theta.sin_cos();
    let mu_star = (1.0 + 3.0 * c * c) / (3.0 * s * c);
    let q = [0.0, -l * s, theta];
    let qd = [-0.3, 0.0, 0.0];
    for factor in [1.0, 1.0 + 1e-13, 1.0 - 1e-13] {
        let mu = mu_star * factor;
        let model = coulomb_body(m, m * l * l / 3.0, &[("end", -l, 0.0)], mu, mu);
        let mut data = Data::new(&model);
        let r = slide_on_flat(&model, &mut data, &[0], &q, &qd, &[]);
        assert!(
            matches!(
                r,
                Err(CoreError::SingularKkt { .. } | CoreError::PainleveInconsistent { .. })
            ),
            "μ/μ* = {factor}: {r:?}"
        );
    }
}
