//! A sprung leg — a massive hip link carrying a massless knee link with a spring–damper at
//! the knee — whose toe slides with Coulomb friction. The toe's normal row pins the massless
//! knee, so the knee's row of (5.2) is its statics and sets the toe's force: the spring's
//! torque balances the ground force's moment about the knee. The folded system's normal
//! response `W⁻¹` of such a pin is zero (infinitely stiff): Painlevé's consistency test
//! must not read its round-off as a wrong sign (it did: the compliant-leg probe's sprung legs
//! with sliding toes ended `PainleveInconsistent` at a response of −3e-16).
//!
//! Independent route: the knee's virtual work. With `J_k = ∂p_toe/∂δ` by central differences
//! of the toe's position (`contact_points`) and the ground force on the robot written from
//! Coulomb's law by hand, `F = (−μ_k |λ_n| sign v_x, λ_n)` (NED, flat ground: pushing normal
//! negative, friction against the toe's sliding velocity `v_x`, itself by differences), the
//! massless knee's row reads `J_k · F + τ_knee = 0` with `τ_knee = −k (δ − δ₀) − c δ̇`
//! (`selfmanip_core::passive`).
mod common;

use common::{one_leg_body, sliding};
use selfmanip_core::{contact_points, forward_dynamics, Data, FlatGround, Model};

const MU: f64 = 0.8;
const K: f64 = 120.0;
const REST: f64 = 1.5;
const DAMP: f64 = 0.4;

fn sprung_leg() -> Model {
    let text = format!(
        r#"
[[legs.links]]
length_m = 0.177
mass_kg = 0.126
inertia_kg_m2 = 0.00092
[[legs.links]]
length_m = 0.05
spring = {{ stiffness_n_m_per_rad = {K}, rest_angle_rad = {REST}, damping_n_m_s_per_rad = {DAMP} }}
[[contacts]]
name = "toe"
leg = "leg"
shape = {{ kind = "point", position_m = [0.0, 0.05] }}
friction = {{ kind = "sticking", mu = {MU}, mu_kinetic = {MU} }}
"#
    );
    one_leg_body("sprung leg", 0.0, &text)
}

fn toe(model: &Model, q: &[f64]) -> [f64; 2] {
    contact_points(model, &FlatGround, q, &vec![0.0; q.len()]).unwrap()[0].position_m
}

#[test]
fn sprung_legs_sliding_toe_force_is_set_by_the_knee_statics() {
    let model = sprung_leg();
    let mode = sliding(&[0]);
    let mut data = Data::new(&model);
    for (hip, knee, phi, hip_tau, vx) in [
        (0.5, 1.62, 0.05, 2.0, 0.3),
        (-0.4, 1.58, -0.1, -1.5, -0.25),
        (0.7, 1.66, 0.0, 0.8, -0.4),
    ] {
        // q = [hip, knee, x, z, φ], the toe on the ground
        let mut q = vec![hip, knee, 0.0, 0.0, phi];
        let p = toe(&model, &q);
        q[2] -= p[0];
        q[3] -= p[1];
        // the body moving; the knee's rate keeps the toe on the ground (A_n q̇ = 0)
        let mut qd = vec![0.3, 0.0, vx, -0.02, 0.1];
        let mut prep = Data::new(&model);
        prep.prepare_geometry(&model, &FlatGround, mode, &q, &qd)
            .unwrap();
        let a = &prep.constraints.a;
        let rest: f64 = [0, 2, 3, 4].iter().map(|&k| a[(0, k)] * qd[k]).sum();
        qd[1] = -rest / a[(0, 1)];

        forward_dynamics(
            &model,
            &mut data,
            &FlatGround,
            mode,
            &q,
            &qd,
            &[hip_tau, 0.0],
            None,
        )
        .expect("a massless knee pinned by a sliding toe is regular and consistent");
        let lambda_n = data.lambda[0];
        assert!(lambda_n < 0.0, "the toe pushes: λ_n = {lambda_n}");

        // the toe's position derivatives by central differences
        let h = 1e-6;
        let diff = |dir: &[f64]| {
            let plus: Vec<f64> = q.iter().zip(dir).map(|(a, b)| a + h * b).collect();
            let minus: Vec<f64> = q.iter().zip(dir).map(|(a, b)| a - h * b).collect();
            let (pp, pm) = (toe(&model, &plus), toe(&model, &minus));
            [(pp[0] - pm[0]) / (2.0 * h), (pp[1] - pm[1]) / (2.0 * h)]
        };
        let j_knee = diff(&[0.0, 1.0, 0.0, 0.0, 0.0]);
        let v = diff(&qd);
        assert!(
            v[1].abs() < 1e-6,
            "the toe stays on the ground: v_z = {}",
            v[1]
        );
        assert!(v[0].abs() > 1e-3, "the toe slides: v_x = {}", v[0]);
        let force = [-MU * lambda_n.abs() * v[0].signum(), lambda_n];
        let tau_knee = -K * (knee - REST) - DAMP * qd[1];
        let balance = j_knee[0] * force[0] + j_knee[1] * force[1] + tau_knee;
        assert!(
            balance.abs() < 1e-6 * (1.0 + tau_knee.abs()),
            "knee statics J_k·F + τ_knee = {balance:e} (τ_knee = {tau_knee}, F = {force:?})"
        );
    }
}
