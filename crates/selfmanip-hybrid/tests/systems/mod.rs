//! Small systems with closed-form answers, shared by the engine's stage tests (as Drake keeps
//! them in `test_utilities/`): rigid bodies with point contacts (a block, a bar, a puck) and a
//! body with one leg.
//!
//! Frames (docs/conventions.md): NED, z down; `q = [θ…, x, z, φ]`; a body-frame point `p`
//! is at `X + R(φ) p` with `R(φ) = [[cos φ, sin φ], [−sin φ, cos φ]]` acting on `(x, z)`, so a
//! point at offset `r = R(φ) p` from the centre moves at `v + φ̇ (r_z, −r_x)` and a force `F`
//! there has the moment `r_z F_x − r_x F_z` about `+y`.
#![allow(dead_code)]
mod fd;
pub use fd::{end_state_and_events, run_jacobian_fd};
use nalgebra::DMatrix;
use selfmanip_core::description::{
    BodyDescription, ContactDescription, FrictionDescription, JointAxis, LegDescription,
    LinkDescription, ShapeDescription,
};
use selfmanip_core::{
    ContactKind, ContactMode, FlatGround, GroundPlane, Model, RobotDescription, Terrain,
};
use selfmanip_hybrid::integrate::StepOptions;
use selfmanip_hybrid::sensitivity::{simulate_with_sensitivity, Sensitivity, SensitivityError};
use selfmanip_hybrid::{
    energy_report, simulate, ControlPoint, Controller, ControllerPartials, Event, EventKind,
    Execution, HybridOptions, ZeroTorque,
};

pub const G: f64 = 9.81;

/// How a point contact resists sliding.
#[derive(Clone, Copy)]
pub enum Friction {
    /// Sticking, with a Coulomb coefficient (`None`: never slips); sliding frictionlessly
    /// (`mu_kinetic = 0`, the thesis's Assumption 5.9).
    Stick(Option<f64>),
    Slide,
    /// Sticking with Coulomb's `μ`, sliding with the same kinetic coefficient.
    Coulomb(f64),
}

/// A rigid body without legs and with point contacts `(name, x, z, friction)` in its frame.
pub fn body(
    mass_kg: f64,
    inertia_kg_m2: f64,
    gravity_m_s2: f64,
    points: &[(&str, f64, f64, Friction)],
) -> Model {
    let mut text = format!(
        "name = \"body\"\ngravity_m_s2 = {gravity_m_s2}\nlegs = []\n[body]\nmass_kg = {mass_kg}\ninertia_kg_m2 = {inertia_kg_m2}\n"
    );
    for (name, x, z, friction) in points {
        let friction = match friction {
            Friction::Stick(None) => "{ kind = \"sticking\" }".to_string(),
            Friction::Stick(Some(mu)) => {
                format!("{{ kind = \"sticking\", mu = {mu}, mu_kinetic = 0 }}")
            }
            Friction::Slide => "{ kind = \"sliding\" }".to_string(),
            Friction::Coulomb(mu) => {
                format!("{{ kind = \"sticking\", mu = {mu}, mu_kinetic = {mu} }}")
            }
        };
        text += &format!(
            "[[contacts]]\nname = \"{name}\"\nshape = {{ kind = \"point\", position_m = [{x}, {z}] }}\nfriction = {friction}\n"
        );
    }
    RobotDescription::from_toml_str(&text)
        .unwrap()
        .build()
        .unwrap()
}

/// The block of the thesis's rocking example: width, height, mass.
pub const BLOCK: (f64, f64, f64) = (0.05, 0.10, 5.0);

/// Centroidal inertia of a uniform `w × h` block of mass `m`.
pub fn block_inertia(w: f64, h: f64, m: f64) -> f64 {
    m * (w * w + h * h) / 12.0
}

/// The block with sticking bottom corners `left` (−w/2, h/2) and `right` (w/2, h/2).
pub fn block(gravity_m_s2: f64) -> Model {
    let (w, h, m) = BLOCK;
    body(
        m,
        block_inertia(w, h, m),
        gravity_m_s2,
        &[
            ("left", -w / 2.0, h / 2.0, Friction::Stick(None)),
            ("right", w / 2.0, h / 2.0, Friction::Stick(None)),
        ],
    )
}

/// A 2 kg puck whose foot is at its centre of mass (no toppling moment).
pub fn puck(mu: f64) -> Model {
    body(
        2.0,
        0.01,
        G,
        &[("foot", 0.0, 0.0, Friction::Stick(Some(mu)))],
    )
}

/// `R(φ) p`.
pub fn rotate(phi: f64, p: [f64; 2]) -> [f64; 2] {
    let (s, c) = phi.sin_cos();
    [c * p[0] + s * p[1], -s * p[0] + c * p[1]]
}

/// A body of `mass_kg` and `inertia_kg_m2` with one leg of the one link `link` hanging
/// from the body's centre, ending in the point toe `toe` at the link's end with
/// `toe_friction`; no other contact. `q = [θ, x, z, φ]`.
pub fn one_link_leg(
    mass_kg: f64,
    inertia_kg_m2: f64,
    gravity_m_s2: f64,
    link: LinkDescription,
    toe_friction: FrictionDescription,
) -> RobotDescription {
    let toe = ContactDescription {
        name: "toe".into(),
        leg: Some("leg".into()),
        link: None,
        shape: ShapeDescription::Point {
            position_m: [0.0, link.length_m],
        },
        friction: toe_friction,
    };
    RobotDescription {
        name: "one leg".into(),
        gravity_m_s2,
        body: BodyDescription {
            mass_kg,
            inertia_kg_m2,
            collision: Vec::new(),
        },
        legs: vec![LegDescription {
            name: "leg".into(),
            hip_m: [0.0, 0.0],
            links: vec![link],
        }],
        contacts: vec![toe],
    }
}

/// A link of `length_m` and `mass_kg` along `+z` (uniform: inertia `m l²/12`, centre of
/// mass at mid-length), without spring or armature.
pub fn uniform_link(length_m: f64, mass_kg: f64) -> LinkDescription {
    LinkDescription {
        length_m,
        mass_kg,
        inertia_kg_m2: mass_kg * length_m * length_m / 12.0,
        com_m: Some([0.0, length_m / 2.0]),
        axis: JointAxis::PlusY,
        spring: None,
        armature_kg_m2: 0.0,
        collision: Vec::new(),
    }
}

/// A body (mass 3 kg, inertia 0.05) with one leg of one link of `length_m` hanging from the
/// body's centre, ending in a sticking point toe (`μ = 1`), and a frictionless belly point
/// 5 cm below the centre; the link is massless when `link_mass_kg` is 0.
pub fn one_leg(length_m: f64, link_mass_kg: f64, gravity_m_s2: f64) -> Model {
    let toe_friction = FrictionDescription::Sticking {
        mu: Some(1.0),
        mu_kinetic: Some(0.0),
    };
    let link = uniform_link(length_m, link_mass_kg);
    let mut d = one_link_leg(3.0, 0.05, gravity_m_s2, link, toe_friction);
    d.contacts.push(body_point(
        "belly",
        [0.0, 0.05],
        FrictionDescription::Sliding,
    ));
    d.build().unwrap()
}

/// A contact point fixed to the body at `position_m` (body coordinates).
pub fn body_point(
    name: &str,
    position_m: [f64; 2],
    friction: FrictionDescription,
) -> ContactDescription {
    ContactDescription {
        name: name.into(),
        leg: None,
        link: None,
        shape: ShapeDescription::Point { position_m },
        friction,
    }
}

/// A legless body (three coordinates) released at rest at `q` in `mode` on flat ground,
/// without torques, run to `t_final`.
pub fn released(
    model: &Model,
    mode: ContactMode,
    q: &[f64; 3],
    t_final: f64,
    opts: HybridOptions,
) -> Execution {
    simulate(
        model,
        &FlatGround,
        &ZeroTorque,
        mode,
        q,
        &[0.0; 3],
        t_final,
        opts,
    )
    .unwrap()
}

/// The first event of a run released at rest with its lowest contact `d` above flat ground,
/// checked to be a touchdown at the free-fall time `√(2d/g)` (to 1e-9 s).
pub fn free_fall_touchdown(exec: &Execution, d: f64) -> &Event {
    let first = &exec.events[0];
    assert_eq!(first.kind, EventKind::Touchdown, "d={d}");
    let expected = (2.0 * d / G).sqrt();
    assert!(
        (first.t - expected).abs() < 1e-9,
        "d={d}: {} vs {expected}",
        first.t
    );
    first
}

/// A run without torques on `terrain` from `(q, q̇)` in `mode` to `t_final`, at the default
/// options.
pub fn coast(
    model: &Model,
    terrain: &dyn Terrain,
    mode: ContactMode,
    (q, qd): (&[f64], &[f64]),
    t_final: f64,
) -> Execution {
    let opts = HybridOptions::default();
    simulate(model, terrain, &ZeroTorque, mode, q, qd, t_final, opts).unwrap()
}

/// [`coast`] on level ground (`z = 0`) with contact 0 sliding and no other contact.
pub fn coast_sliding_on_level(model: &Model, (q, qd): (&[f64], &[f64]), t_final: f64) -> Execution {
    coast(
        model,
        &GroundPlane::level(0.0),
        sliding(&[0]),
        (q, qd),
        t_final,
    )
}

/// A run on flat ground under `ctrl` from `(q, q̇)` with contact 0 (a leg's toe) sliding and
/// no other contact, to `t_final` with the options `opts`.
pub fn toe_sliding_run(
    model: &Model,
    ctrl: &dyn Controller,
    q: &[f64],
    qd: &[f64],
    t_final: f64,
    opts: HybridOptions,
) -> Execution {
    let mode = sliding(&[0]);
    simulate(model, &FlatGround, ctrl, mode, q, qd, t_final, opts).unwrap()
}

/// The options of the fold tests: the fold threshold `ε = fold_threshold`, a stop at the
/// apex, rtol 1e-11 (atol 1e-13).
pub fn fold_options(fold_threshold: f64) -> HybridOptions {
    HybridOptions {
        fold_threshold,
        stop_at_apex: true,
        step: StepOptions {
            rtol: 1e-11,
            atol: 1e-13,
            ..StepOptions::default()
        },
        ..HybridOptions::default()
    }
}

/// A sled's slide (`tests/data/robots/sled.toml`): a run on flat ground under `ctrl` from
/// `(q, q̇)` with the toe and both skids sliding, to `t_final`, at rtol 1e-10 (atol 1e-12).
pub fn sled_slide(
    model: &Model,
    ctrl: &dyn Controller,
    (q, qd): (&[f64], &[f64]),
    t_final: f64,
) -> Execution {
    let mut opts = HybridOptions::default();
    (opts.step.rtol, opts.step.atol) = (1e-10, 1e-12);
    let mode = sliding(&[0, 1, 2]);
    simulate(model, &FlatGround, ctrl, mode, q, qd, t_final, opts).unwrap()
}

/// The energy balance of `exec` on flat ground closes, and friction took the kinetic energy
/// `t0_j`, both to 1e-6 relative.
pub fn assert_friction_took(model: &Model, exec: &Execution, t0_j: f64) {
    let rep = energy_report(model, &FlatGround, exec).unwrap();
    let t0 = t0_j;
    assert!(
        (rep.friction_work_j + t0).abs() < 1e-6 * t0,
        "{rep:?} vs -{t0}"
    );
    assert!(rep.residual_j().abs() < 1e-6 * t0, "{rep:?}");
}

/// The default options with steps of at most 1 ms (runs with many steps per segment).
pub fn short_steps() -> HybridOptions {
    HybridOptions {
        step: StepOptions {
            h_max_s: 1e-3,
            ..StepOptions::default()
        },
        ..HybridOptions::default()
    }
}

/// Painlevé's rod: a uniform rod of `mass_kg` and half-length `half_length_m` (`I = m l²/3`)
/// whose end `end`, at `(−l, 0)`, is a Coulomb point with `μ = mu`.
pub fn painleve_rod(mass_kg: f64, half_length_m: f64, mu: f64) -> Model {
    let l = half_length_m;
    body(
        mass_kg,
        mass_kg * l * l / 3.0,
        G,
        &[("end", -l, 0.0, Friction::Coulomb(mu))],
    )
}

/// The friction coefficient `μ* = (1 + 3cos²θ)/(3 sinθ cosθ)` above which the rod leaning at
/// `θ` has no consistent slide with its end moving away from its centre (its normal
/// response `1 + 3cos²θ − 3μ sinθ cosθ` vanishes there).
pub fn painleve_mu_star(theta: f64) -> f64 {
    let (s, c) = theta.sin_cos();
    (1.0 + 3.0 * c * c) / (3.0 * s * c)
}

/// A body with one massless one-link leg of `length_m` at its centre, ending in the point
/// toe `toe` with `toe_friction`; no other contact. `q = [θ, x, z, φ]`.
pub fn massless_leg(
    mass_kg: f64,
    inertia_kg_m2: f64,
    length_m: f64,
    toe_friction: FrictionDescription,
) -> Model {
    let link = LinkDescription {
        com_m: None,
        ..uniform_link(length_m, 0.0)
    };
    one_link_leg(mass_kg, inertia_kg_m2, G, link, toe_friction)
        .build()
        .unwrap()
}

/// The mode with `contacts` touching as `kind` and no other contact.
pub fn touching(kind: ContactKind, contacts: &[usize]) -> ContactMode {
    contacts
        .iter()
        .fold(ContactMode::FLIGHT, |m, &k| m.with(k, kind))
}

/// The mode with `contacts` sliding and no other contact.
pub fn sliding(contacts: &[usize]) -> ContactMode {
    touching(ContactKind::Slide, contacts)
}

/// The mode with `contacts` sticking and no other contact.
pub fn sticking(contacts: &[usize]) -> ContactMode {
    touching(ContactKind::Stick, contacts)
}

/// Hip servos `Υ_i = −k (θ_i − θ_i*) − c θ̇_i` with their partials, and the gain `k` as a
/// parameter (`"k"`): the controller of the drops of the whole-execution sensitivity tests.
#[derive(Debug, Clone)]
pub struct Servos {
    pub k: f64,
    pub c: f64,
    pub target: Vec<f64>,
}

impl Controller for Servos {
    fn torque(&self, _t: f64, q: &[f64], qd: &[f64], _mode: ContactMode, tau: &mut [f64]) {
        for (i, t) in tau.iter_mut().enumerate() {
            *t = -self.k * (q[i] - self.target[i]) - self.c * qd[i];
        }
    }
    fn partials(&self, _at: &ControlPoint, out: &mut ControllerPartials) -> bool {
        for i in 0..self.target.len() {
            out.dtau.dq[(i, i)] = -self.k;
            out.dtau.dqd[(i, i)] = -self.c;
        }
        true
    }
    fn parameter_partials(
        &self,
        at: &ControlPoint,
        names: &[&str],
        out: &mut ControllerPartials,
    ) -> bool {
        let ControlPoint { q, .. } = *at;
        for (col, n) in names.iter().enumerate() {
            if *n != "k" {
                return false;
            }
            for (i, (qi, ti)) in q.iter().zip(&self.target).enumerate() {
                out.dtau_dp[(i, col)] = -(qi - ti);
            }
        }
        true
    }
}

/// Tolerances for derivatives against central differences of whole runs (rtol 1e-12,
/// events to 1e-14 s, free joints in the step-size control).
pub fn tight() -> HybridOptions {
    HybridOptions {
        step: StepOptions {
            rtol: 1e-12,
            atol: 1e-14,
            ..StepOptions::default()
        },
        event_tol_s: 1e-14,
        control_free_joints: true,
        ..HybridOptions::default()
    }
}

/// A run from `y0 = (q, q̇)` in flight on flat ground to `tf` with the options `opts`.
pub fn flight_run(
    model: &Model,
    ctrl: &dyn Controller,
    y0: &[f64],
    tf: f64,
    opts: HybridOptions,
) -> Execution {
    let nq = model.nq();
    let mode = ContactMode::FLIGHT;
    simulate(
        model,
        &FlatGround,
        ctrl,
        mode,
        &y0[..nq],
        &y0[nq..],
        tf,
        opts,
    )
    .unwrap()
}

/// [`simulate_with_sensitivity`] of a run on flat ground from `y0 = [q; q̇]` in flight to
/// `tf`, at [`tight`] tolerances.
pub fn flight_sensitivity(
    model: &Model,
    ctrl: &dyn Controller,
    y0: &[f64],
    tf: f64,
) -> Result<(Execution, Sensitivity), SensitivityError> {
    let nq = model.nq();
    simulate_with_sensitivity(
        model,
        &FlatGround,
        ctrl,
        ContactMode::FLIGHT,
        &y0[..nq],
        &y0[nq..],
        tf,
        tight(),
    )
}

/// The Jacobian of [`run_from_flight`]'s end state to its start state `y0` by
/// [`run_jacobian_fd`] in every direction; every perturbed run must meet the events `seq`.
pub fn flight_run_jacobian_fd(
    model: &Model,
    ctrl: &dyn Controller,
    y0: &[f64],
    tf: f64,
    seq: &[EventKind],
    h: f64,
) -> DMatrix<f64> {
    let all: Vec<usize> = (0..y0.len()).collect();
    run_jacobian_fd(|y| run_from_flight(model, ctrl, y, tf), y0, &all, seq, h)
}

/// A run from `y0 = (q, q̇)` in flight on flat ground to `tf` with [`tight`] options: its end
/// state and its event kinds.
pub fn run_from_flight(
    model: &Model,
    ctrl: &dyn Controller,
    y0: &[f64],
    tf: f64,
) -> (Vec<f64>, Vec<EventKind>) {
    let e = flight_run(model, ctrl, y0, tf, tight());
    end_state_and_events(&e)
}

/// A small linear congruential generator (64-bit, Knuth's MMIX constants): a fixed,
/// dependency-free sequence of test states.
pub struct Lcg(pub u64);

impl Lcg {
    /// The next number, uniform in `[lo, hi)`.
    pub fn uniform(&mut self, lo: f64, hi: f64) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        lo + (hi - lo) * ((self.0 >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// The check of both allocation tests (`stage_allocations.rs`, `sensitivity_allocations.rs`):
/// `steps_and_allocations(mode, q, t_final)` — the steps of a run's single segment and the
/// allocations of the stage measured — for the block falling from 100 m (no rows; touchdown
/// guards sampled at every step) and standing on its corners (two contacts' rows; liftoff and
/// slip→stick guards: a flow evaluation per sample), to 1 s and to 2 s. Doubling the steps (at least 900 more) may add only the few allocations of the buffers'
/// growth and the per-segment work (at most 12), not one per step.
pub fn assert_doubling_the_steps_adds_no_allocations(
    steps_and_allocations: impl Fn(&str, [f64; 3], f64) -> (usize, usize),
) {
    let (_, h, _) = BLOCK;
    for (mode, q) in [
        ("", [0.0, -100.0, 0.0]),
        ("left,right:slide", [0.0, -h / 2.0, 0.0]),
    ] {
        let (n1, a1) = steps_and_allocations(mode, q, 1.0);
        let (n2, a2) = steps_and_allocations(mode, q, 2.0);
        eprintln!("mode `{mode}`: {a1} allocations for {n1} steps, {a2} for {n2}");
        assert!(n2 >= n1 + 900, "mode `{mode}`: {n1} and {n2} steps");
        assert!(
            a2 <= a1 + 12,
            "mode `{mode}`: {a1} allocations for {n1} steps, {a2} for {n2}"
        );
    }
}
