//! Candidate (a) of issue 16's pitch question, measured where the core can represent it:
//! compliant legs with **pinned toes** (chapter 3's own assumption for the same-sign
//! strategies, section 3.1.2 footnote 5). A compliant *massless* leg cannot slide (two
//! massless coordinates, one row: Lemma 5.1; `selfmanip_core::passive` module docs); with
//! `MASS=1` the legs carry Table 4.2's pair mass on the hip's link, the massless knee is
//! pinned by the toe alone, and `SLIDE=1` gives the toes the default leap's Coulomb law
//! (`docs/decisions/2026-11-24-pitch-default-unchanged.md`). By default this compares pinned rigid
//! legs with pinned compliant ones, everything else as in the default leap.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin compliant_leg_probe -- ++ 0 2000,4000,8000,1e6
//! ```
//! Arguments: strategy, t2 (s, the rear motor's start after the front one's), radial
//! stiffnesses of a leg pair (N/m, at the leg's rest shape; `rigid` for the one-joint rigid
//! leg of the same length). `ZETA` is the damping ratio (default 0.2), `KNEE=-1` bends the
//! knee the other way, `EVENTS=1` lists the first events, `SLIDE=1` and `MASS=1` as above.
//!
//! **The leg.** A point-toe leg of length `ρ = 0.17 m` (a stick leg: the half-circle's
//! rolling contact would need the arc on a bending link) made of two massless links: hip to
//! knee `c = √(ρ² + e²)`, knee to toe `e` = [`KNEE_OFFSET_M`], with a torsional
//! spring–damper at the knee whose rest bend puts the knee–toe link at right angles to the
//! hip–toe line ([`geometry`]). A force across that line then passes through the knee (the
//! leg is stiff across, and the motor's torque reaches the toe as `τ/ρ` as on the rigid
//! leg), and a force along it loads the spring on the lever `e`: a radial spring of
//! stiffness `k_r = k_θ / e²` (core's kinematics: `tests/compliant_leg.rs`), damped at ratio
//! ζ for half the body's mass on one leg. In the air the knee keeps its rest bend before
//! touchdown and the bend it left with after liftoff (a massless spring has nothing to load
//! there; relaxing, a loaded one would drive the toe back into the ground at once), and the
//! hip follows the default leap's motions: from its hold angle, `wait_clearance_rad` above
//! touchdown, at the motor's no-load speed and stall acceleration (`leap::leg_swing`);
//! after its liftoff a leg parks pointing up, held there on the ground by the leap's
//! servo. Motors: the default geared X-RHex drive (`leap::leg_actuator`), torque by the
//! hip's speed. δt = 0.03 s. The `rigid` leg is the same controller on one joint: it
//! reproduces `simulate_leap` with stick legs and pinned toes.
use rhex_model::leap::{leap_params, leg_actuator, leg_swing, LeapConfig};
use rhex_model::params::LegPair;
use selfmanip_core::passive;
use selfmanip_core::{ContactMode, FlatGround, Model, RobotDescription};
use selfmanip_hybrid::{simulate, Controller, Event, EventKind, HybridOptions, StepOptions};
use selfmanip_sim::motion::JointMotion;
use std::sync::Arc;

const STOW: f64 = 2.6;
/// Knee-to-toe offset of the sprung leg (m).
pub const KNEE_OFFSET_M: f64 = 0.05;

/// The sprung leg's geometry: knee-to-toe offset `e` = [`KNEE_OFFSET_M`],
/// hip-to-knee `c = √(ρ² + e²)`, rest bend `δ₀ = s (π/2 + atan(e/ρ))`: the knee–toe link
/// stands at right angles to the hip–toe line, so at rest a force across that line passes
/// through the knee (stiff) and one along it loads the spring on the lever `e`
/// (`k_r = k_θ / e²`). Returns `(c, e, δ₀)`.
pub fn geometry(rho: f64, side: f64) -> (f64, f64, f64) {
    let e = KNEE_OFFSET_M;
    (
        rho.hypot(e),
        e,
        side * (0.5 * std::f64::consts::PI + (e / rho).atan()),
    )
}

/// Angle of the hip–toe line relative to the first link at knee bend `δ` (both joints turn
/// the same way).
fn line_offset(c: f64, e: f64, delta: f64) -> f64 {
    (e * delta.sin()).atan2(c + e * delta.cos())
}

/// How the toes meet the ground and what the legs weigh ([`robot`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Toes {
    /// Coulomb-sliding toes (the default leap's law: `μ_k = μ`, Fig. 5.1's μ per pair)
    /// instead of pinned ones.
    pub sliding: bool,
    /// Table 4.2's leg-pair mass and inertia (0.126 kg, 0.00092 kg m²) on the hip's link —
    /// the hip–knee link of a sprung leg, whose knee–toe link stays massless — instead of
    /// massless legs. A sprung leg with a sliding toe needs it: two massless joints and one
    /// normal row leave the folded KKT system singular (Lemma 5.1), while a massless knee
    /// under a massive hip link is resolved by the knee's statics, the spring setting the
    /// toe's force.
    pub leg_mass: bool,
}

/// Table 4.2's leg-pair mass and inertia about its centre (kg, kg m²).
const LEG_PAIR_MASS: (f64, f64) = (0.126, 0.00092);

/// The robot: body of Table 4.2 with its rounded ends, two leg pairs (`pairs`), each a
/// point-toe leg of length ρ, rigid (`k_r = None`) or a sprung two-link chain.
pub fn robot(
    pairs: [LegPair; 2],
    k_r: Option<f64>,
    knee_side: f64,
    zeta: f64,
    toes: Toes,
) -> Model {
    let p = leap_params();
    let (m, i) = if toes.leg_mass {
        LEG_PAIR_MASS
    } else {
        (0.0, 0.0)
    };
    let rho = p.rho1;
    let mut text = format!(
        "name = \"compliant-leg RHex\"\ngravity_m_s2 = {}\n[body]\nmass_kg = {}\ninertia_kg_m2 = {}\n",
        p.g, p.m_b, p.I_b
    );
    for pair in pairs {
        text += &format!(
            "[[legs]]\nname = \"{}\"\nhip_m = [{}, 0.0]\n",
            pair.name(),
            p.hip_x(pair)
        );
        match k_r {
            None => {
                text += &format!(
                    "[[legs.links]]\nlength_m = {rho}\nmass_kg = {m}\ninertia_kg_m2 = {i}\naxis = \"-y\"\n"
                );
            }
            Some(k) => {
                let (c, e, d0) = geometry(rho, knee_side);
                let k_theta = k * e * e;
                // damping ratio ζ of the body bouncing on this leg alone (half the body's
                // mass): c_r = 2 ζ √(k_r m_b/2), at the knee c_r e²
                let c_theta = 2.0 * zeta * (k * 0.5 * p.m_b).sqrt() * e * e;
                text += &format!(
                    "[[legs.links]]\nlength_m = {c}\nmass_kg = {m}\ninertia_kg_m2 = {i}\naxis = \"-y\"\n[[legs.links]]\nlength_m = {e}\naxis = \"-y\"\nspring = {{ stiffness_n_m_per_rad = {k_theta}, rest_angle_rad = {d0}, damping_n_m_s_per_rad = {c_theta} }}\n"
                );
            }
        }
    }
    for pair in pairs {
        let len = match k_r {
            None => rho,
            Some(_) => geometry(rho, knee_side).1,
        };
        let friction = if toes.sliding {
            let mu = match pair {
                LegPair::Front => p.mu_front,
                LegPair::Middle => p.mu_middle,
                LegPair::Rear => p.mu_rear,
            }
            .expect("the default leap gives every toe its μ");
            format!("{{ kind = \"sticking\", mu = {mu}, mu_kinetic = {mu} }}")
        } else {
            "{ kind = \"sticking\" }".to_string()
        };
        text += &format!(
            "[[contacts]]\nname = \"{0}_leg\"\nleg = \"{0}\"\nshape = {{ kind = \"point\", position_m = [0.0, {len}] }}\nfriction = {friction}\n",
            pair.name()
        );
    }
    for (name, x) in [("front_body", p.l1), ("rear_body", -p.l2)] {
        text += &format!(
            "[[contacts]]\nname = \"{name}\"\nshape = {{ kind = \"circle\", center_m = [{x}, 0.0], radius_m = {} }}\nfriction = {{ kind = \"sliding\" }}\n",
            p.rho_b
        );
    }
    RobotDescription::from_toml_str(&text)
        .expect("the description parses")
        .build()
        .expect("the description builds")
}

#[derive(Clone)]
struct Ctrl {
    /// Hip joint index of each leg, and its knee (if sprung).
    hip: [usize; 2],
    knee: [Option<usize>; 2],
    rest: f64,
    /// `(c, e, δ₀)` of the sprung leg.
    geom: (f64, f64, f64),
    sign: [f64; 2],
    start: [f64; 2],
    hold: [f64; 2],
    accel: f64,
    actuator: Arc<dyn motor::Actuator>,
    air: [Vec<JointMotion>; 2],
    lifted: [bool; 2],
    takeoff: bool,
    /// Whether each leg's retraction has its motion (planned once).
    parked: [bool; 2],
    /// Whether the hips carry the legs' mass: then a hip in the air is no free massless
    /// joint and follows its motion by the servo instead of a prescribed acceleration.
    massive_hips: bool,
}

impl Ctrl {
    fn motion(&self, i: usize, t: f64) -> (f64, f64, f64) {
        if t < self.start[i] {
            return (self.hold[i], 0.0, 0.0);
        }
        let m = self.air[i]
            .iter()
            .rev()
            .find(|m| m.t0() <= t)
            .unwrap_or(&self.air[i][0]);
        m.eval(t)
    }
    fn pushing(&self, i: usize, t: f64) -> bool {
        t >= self.start[i] && !self.lifted[i] && !self.takeoff
    }
}

impl Controller for Ctrl {
    fn torque(&self, t: f64, q: &[f64], qd: &[f64], mode: ContactMode, tau: &mut [f64]) {
        tau.fill(0.0);
        for i in 0..2 {
            let h = self.hip[i];
            if self.pushing(i, t) {
                tau[h] = self.actuator.joint_torque_n_m(self.sign[i], qd[h]);
            } else if mode.contains(i) || self.massive_hips {
                // a retracting leg on the ground — and a massive one in the air — follows
                // its motion in the air with the leap's servo (stall-torque-limited PD), as
                // the leap preset's retract phase does on the ground
                let stall = self.actuator.joint_torque_n_m(1.0, 0.0);
                let (th, om, _) = self.motion(i, t);
                tau[h] =
                    (-20.0 * stall * (q[h] - th) - 0.5 * stall * (qd[h] - om)).clamp(-stall, stall);
            }
        }
    }
    fn free_joint_qdd(&self, t: f64, q: &[f64], qd: &[f64], free: &[usize], out: &mut [f64]) {
        for (o, &j) in out.iter_mut().zip(free) {
            *o = 0.0;
            for i in 0..2 {
                if j == self.hip[i] {
                    // the hip follows the leg's motion in the air
                    let (th, om, al) = self.motion(i, t);
                    *o = al + 400.0 * (th - q[j]) + 40.0 * (om - qd[j]);
                } else if Some(j) == self.knee[i] {
                    if self.lifted[i] || self.takeoff {
                        // after its liftoff the knee keeps the bend it left with (its rate
                        // damped out): relaxing, a loaded spring would extend the leg back
                        // into the ground at once
                        *o = -400.0 * qd[j];
                    } else {
                        let s = selfmanip_core::model::JointSpring {
                            stiffness_n_m_per_rad: 1.0,
                            cubic_stiffness_n_m_per_rad3: 0.0,
                            damping_n_m_s_per_rad: 0.0,
                            rest_angle_rad: self.rest,
                        };
                        *o = passive::relaxation_qdd(&s, q[j], qd[j], 400.0);
                    }
                }
            }
        }
    }
    /// The motors' starts and the knots of every motion in the air, where the torque or the
    /// prescribed acceleration jumps: the engine's steps land on them, as they do on
    /// the leap preset's (`data/behaviours/leap_*.toml`).
    fn time_events(&self, names: &[&str]) -> Vec<selfmanip_hybrid::TimeEvent> {
        let at = |t: f64| selfmanip_hybrid::TimeEvent {
            t,
            dt_dp: vec![0.0; names.len()],
        };
        let mut out: Vec<_> = self.start.iter().map(|&t| at(t)).collect();
        for m in self.air.iter().flatten() {
            out.extend(std::iter::once(m.t0()).chain(m.knots()).map(at));
        }
        out
    }
    fn on_event(&mut self, e: &Event) {
        let both = e.t >= self.start[0].max(self.start[1]);
        if both && e.mode_after.is_flight() {
            self.takeoff = true;
        }
        for i in 0..2 {
            let c = i; // contacts 0 and 1 are the toes
            let left = e.mode_before.contains(c) && !e.mode_after.contains(c);
            if left && e.t >= self.start[i] {
                self.lifted[i] = true;
            }
            // a leg retracts along one motion, planned when it first retracts in the air; a
            // leg the ground releases later returns to it (as the leap preset's retract phase does)
            if (left || self.takeoff)
                && e.t >= self.start[i]
                && !e.mode_after.contains(c)
                && !self.parked[i]
            {
                self.parked[i] = true;
                let h = self.hip[i];
                // parks pointing up on the side of straight down where its line is
                let off = |d: f64| line_offset(self.geom.0, self.geom.1, d);
                let line = e.q[h] + self.knee[i].map_or(0.0, |k| off(e.q[k]));
                let side = if self.sign[i] * line >= 0.0 {
                    self.sign[i]
                } else {
                    -self.sign[i]
                };
                let target = side * STOW - self.knee[i].map_or(0.0, |k| off(e.q[k]));
                self.air[i].push(JointMotion::park(
                    e.t,
                    e.q[h],
                    e.qd_after[h],
                    target,
                    self.accel,
                ));
            }
        }
    }
}

/// A leap's apex (z up, from the start), or how it ended.
#[derive(Debug, Clone)]
pub struct Outcome {
    pub apex: Option<[f64; 4]>,
    /// `[z m, x m, pitch rad, pitch rate rad/s]` at the apex (see `apex`); otherwise the
    /// termination.
    pub ended: String,
    pub steps: usize,
    /// Toe and body-end contact bits per segment (middle/front toe, rear/middle toe, front
    /// body, rear body), repeats merged.
    pub word: String,
}

/// Runs one leap with pinned toes: rigid legs (`k_r = None`) or sprung ones of radial
/// stiffness `k_r` (N/m per pair) and damping ratio `zeta`.
pub fn leap(
    strategy: &str,
    t2: f64,
    k_r: Option<f64>,
    knee_side: f64,
    zeta: f64,
    toes: Toes,
) -> Outcome {
    let p = leap_params();
    let cfg = LeapConfig {
        strategy: strategy.parse().unwrap(),
        t2_s: t2,
        ..LeapConfig::default()
    };
    let pairs = cfg.strategy.chapter3_pairs();
    let model = robot(pairs, k_r, knee_side, zeta, toes);
    let nq = model.nq();
    let sign = [cfg.strategy.front.sign(), cfg.strategy.rear.sign()];
    let (hip, knee) = match k_r {
        None => ([0, 1], [None, None]),
        Some(_) => ([0, 2], [Some(1), Some(3)]),
    };
    let geom = geometry(p.rho1, knee_side);
    let rest = geom.2;
    // touchdown angle of the hip–toe line from the sitting posture (hip 5 cm up)
    let line_td = -(p.rho_b / p.rho1).acos();
    let mut q0 = vec![0.0; nq];
    let mut hold = [0.0; 2];
    let half = if k_r.is_some() {
        line_offset(geom.0, geom.1, rest)
    } else {
        0.0
    };
    for i in 0..2 {
        // line angle = hip + δ/2 (two equal links); pushing `+` lands pointing forward
        let line = sign[i] * line_td - sign[i] * cfg.wait_clearance_rad;
        hold[i] = line - half;
        q0[hip[i]] = hold[i];
        if let Some(k) = knee[i] {
            q0[k] = rest;
        }
    }
    q0[nq - 2] = -p.rho_b;
    let offset = t2.min(0.0);
    let start = [-offset, t2 - offset];
    let (speed, accel) = leg_swing(&p, &cfg).unwrap();
    let ctrl = Ctrl {
        hip,
        knee,
        rest,
        geom,
        sign,
        start,
        hold,
        accel,
        actuator: leg_actuator(&p, &cfg.actuator).unwrap(),
        air: std::array::from_fn(|i| {
            vec![JointMotion::swing(
                start[i],
                hold[i],
                0.0,
                sign[i] * STOW - half,
                speed,
                accel,
            )]
        }),
        lifted: [false; 2],
        takeoff: false,
        parked: [false, false],
        massive_hips: toes.leg_mass,
    };
    let opts = HybridOptions {
        step: StepOptions {
            rtol: 1e-8,
            atol: 1e-10,
            ..Default::default()
        },
        delta_t_s: cfg.delta_t_s,
        stop_at_apex: true,
        zeno_max_events: 40,
        ..HybridOptions::default()
    };
    let mode0 = ContactMode::with_defaults(&model, &[2, 3]).unwrap();
    let exec = simulate(
        &model,
        &FlatGround,
        &ctrl,
        mode0,
        &q0,
        &vec![0.0; nq],
        1.0 - offset,
        opts,
    );
    let exec = match exec {
        Ok(e) => e,
        Err(e) => {
            return Outcome {
                apex: None,
                ended: format!("error {e}"),
                steps: 0,
                word: String::new(),
            }
        }
    };
    if std::env::var("EVENTS").is_ok() {
        for e in exec.events.iter().take(12) {
            println!(
                "    t {:.6} {:?} {:b} -> {:b} {:?} q {:.4?} qd {:.3?}",
                e.t + offset,
                e.kind,
                e.mode_before.normal_bits(),
                e.mode_after.normal_bits(),
                e.triggered,
                e.q,
                e.qd_after
            );
        }
    }
    let mut word: Vec<String> = Vec::new();
    for s in &exec.segments {
        let bits: String = (0..4)
            .map(|c| if s.mode.contains(c) { '1' } else { '0' })
            .collect();
        if word.last() != Some(&bits) {
            word.push(bits);
        }
    }
    let apex = match exec.events.last() {
        Some(e) if e.kind == EventKind::Apex => {
            Some([-e.q[nq - 2], e.q[nq - 3], e.q[nq - 1], e.qd_after[nq - 1]])
        }
        _ => None,
    };
    Outcome {
        apex,
        ended: format!("{:?}", exec.termination),
        steps: exec.steps,
        word: word.join("-"),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let strategy = args.get(1).map_or("++", String::as_str);
    let t2: f64 = args.get(2).map_or(0.0, |s| s.parse().unwrap());
    let ks = args
        .get(3)
        .map_or("rigid,2000,4000,8000,1e6", String::as_str);
    let side: f64 = std::env::var("KNEE").map_or(1.0, |s| s.parse().unwrap());
    let zeta: f64 = std::env::var("ZETA").map_or(0.2, |s| s.parse().unwrap());
    let toes = Toes {
        sliding: std::env::var("SLIDE").is_ok(),
        leg_mass: std::env::var("MASS").is_ok(),
    };
    for k in ks.split(',') {
        let k_r = (k != "rigid").then(|| k.parse::<f64>().unwrap());
        let o = leap(strategy, t2, k_r, side, zeta, toes);
        match o.apex {
            Some(a) => println!(
                "{strategy} t2 {t2:+.3} k_r {k:>8}: apex z {:.3} m, x {:.3} m, pitch {:+.1} deg, rate {:+.1} deg/s, {} steps; contacts {}",
                a[0],
                a[1],
                a[2].to_degrees(),
                a[3].to_degrees(),
                o.steps,
                o.word
            ),
            None => println!(
                "{strategy} t2 {t2:+.3} k_r {k:>8}: {} after {} steps; contacts {}",
                o.ended, o.steps, o.word
            ),
        }
    }
}
