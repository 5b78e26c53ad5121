//! Compliant legs: a rigid one-link leg with a point toe made a two-link leg with a passive
//! spring–damper at a knee, its mass on the hip link (the core's massive-hip, massless-knee
//! leg: a massless knee is resolved by its statics, so the toe can stick or slide, Lemma 5.1),
//! the knee's law a behaviour law, so that the generic simulator, its named sensitivities and
//! calibration all see it. Nothing here knows a particular robot.
//!
//! **The leg.** A rigid leg of length `ρ` (its toe a point at the link's tip) becomes the
//! hip–knee link of length `c = √(ρ² + e²)` and the knee–toe link of length `e`
//! ([`CompliantLeg::knee_offset_m`]), bent at rest by `δ₀ = s (π/2 + atan(e/ρ))`
//! (`s` = [`CompliantLeg::knee_side`]): the knee–toe link stands at right angles to the
//! hip–toe line, whose length is then `ρ` again and which lies at `β = s atan(e/ρ)` from the
//! hip–knee link ([`KneeGeometry`]). At rest the toe, the link's mass and inertia and the
//! hip–toe line are the rigid leg's: the hip coordinate is the rigid leg's angle less `β`,
//! and every angle the leg's program commands is shifted by `−β` (so that it commands the
//! hip–toe line as the rigid leg's program did).
//!
//! **The spring.** The knee law is `τ = −k_θ (δ − δ₀) − c_θ δ̇` (a servo about `δ₀` without a
//! torque limit, acting while the toe is on the ground; in the air the massless knee holds
//! the bend it left the ground with, by the free-joint gains: a loaded spring relaxing there
//! would drive the toe straight back into the ground). A force across the hip–toe line runs along the
//! knee–toe link, through the knee: the leg is stiff across. A toe displacement `δr` along
//! the line turns the knee by `δr/e` (the lever `e`, perpendicular to the line), whose torque
//! `k_θ δr/e` holds a force `k_θ δr/e²` along the line: a **radial** spring and damper of
//! `k_r = k_θ / e²`, `c_r = c_θ / e²`, to first order in `δr/e` (the line turns with the knee
//! only at second order). A spring may be given either way ([`CompliantLeg`]); the
//! behaviour parameters [`LEG_STIFFNESS`] and [`LEG_DAMPING`] carry it in the units given, and
//! the knee's gains are formulas of them, so their derivatives are the servo gains' exact ones.
use crate::behaviour::{Behaviour, JointProgram, Motion, On, Phase, Torque, Trigger};
use crate::error::SimError;
use crate::expr::Scalar;
use crate::scenario::Scenario;
use selfmanip_core::description::{
    FrictionDescription, LinkDescription, RobotDescription, ShapeDescription,
};
use serde::{Deserialize, Serialize};

/// The behaviour parameter of the leg's stiffness (`k_r` N/m or `k_θ` N m/rad, as given).
pub const LEG_STIFFNESS: &str = "leg_stiffness";
/// The behaviour parameter of the leg's damping (`c_r` N s/m or `c_θ` N m s/rad, as given).
pub const LEG_DAMPING: &str = "leg_damping";

/// A compliant leg's spring–damper: radial (`stiffness_n_per_m`, `damping_n_s_per_m`, along
/// the hip–toe line) **or** angular (`stiffness_n_m_per_rad`, `damping_n_m_s_per_rad`, at the
/// knee), and the knee's geometry. Errors name the field (`compliant_leg.<field>`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CompliantLeg {
    /// Radial stiffness `k_r > 0` (N/m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_n_per_m: Option<f64>,
    /// Radial damping `c_r ≥ 0` (N s/m; default 0), with a radial stiffness.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping_n_s_per_m: Option<f64>,
    /// Angular stiffness at the knee `k_θ > 0` (N m/rad).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stiffness_n_m_per_rad: Option<f64>,
    /// Angular damping at the knee `c_θ ≥ 0` (N m s/rad; default 0), with an angular stiffness.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damping_n_m_s_per_rad: Option<f64>,
    /// Knee-to-toe length `e` (m), the spring's lever: `0 < e < ρ`. Default 0.05.
    #[serde(default = "default_knee_offset")]
    pub knee_offset_m: f64,
    /// Which way the knee bends: `+1` (default) or `−1`.
    #[serde(default = "one")]
    pub knee_side: f64,
}

fn default_knee_offset() -> f64 {
    0.05
}

fn one() -> f64 {
    1.0
}

impl Default for CompliantLeg {
    fn default() -> Self {
        CompliantLeg {
            stiffness_n_per_m: None,
            damping_n_s_per_m: None,
            stiffness_n_m_per_rad: None,
            damping_n_m_s_per_rad: None,
            knee_offset_m: default_knee_offset(),
            knee_side: 1.0,
        }
    }
}

fn invalid(field: &str, reason: impl Into<String>) -> SimError {
    SimError::InvalidValue {
        field: format!("compliant_leg.{field}"),
        reason: reason.into(),
    }
}

impl CompliantLeg {
    /// A radial spring–damper of `k_r` N/m and `c_r` N s/m.
    pub fn radial(stiffness_n_per_m: f64, damping_n_s_per_m: f64) -> Self {
        CompliantLeg {
            stiffness_n_per_m: Some(stiffness_n_per_m),
            damping_n_s_per_m: Some(damping_n_s_per_m),
            ..Self::default()
        }
    }

    /// An angular spring–damper of `k_θ` N m/rad and `c_θ` N m s/rad at the knee.
    pub fn angular(stiffness_n_m_per_rad: f64, damping_n_m_s_per_rad: f64) -> Self {
        CompliantLeg {
            stiffness_n_m_per_rad: Some(stiffness_n_m_per_rad),
            damping_n_m_s_per_rad: Some(damping_n_m_s_per_rad),
            ..Self::default()
        }
    }

    /// Checks every field: one stiffness, positive and finite; its damping finite and not
    /// negative; no damping without its stiffness; `e > 0`; `s = ±1`.
    pub fn validate(&self) -> Result<(), SimError> {
        let forms = [
            (
                "stiffness_n_per_m",
                self.stiffness_n_per_m,
                "damping_n_s_per_m",
                self.damping_n_s_per_m,
            ),
            (
                "stiffness_n_m_per_rad",
                self.stiffness_n_m_per_rad,
                "damping_n_m_s_per_rad",
                self.damping_n_m_s_per_rad,
            ),
        ];
        for (k_field, k, c_field, c) in forms {
            if let Some(k) = k {
                if !(k.is_finite() && k > 0.0) {
                    return Err(invalid(
                        k_field,
                        format!("must be finite and positive, got {k}"),
                    ));
                }
            }
            match (k, c) {
                (_, Some(c)) if !(c.is_finite() && c >= 0.0) => {
                    return Err(invalid(c_field, format!("must be finite and ≥ 0, got {c}")))
                }
                (None, Some(_)) => {
                    return Err(invalid(
                        c_field,
                        format!("damping without its stiffness `{k_field}`"),
                    ))
                }
                _ => {}
            }
        }
        match (self.stiffness_n_per_m, self.stiffness_n_m_per_rad) {
            (None, None) => {
                return Err(invalid(
                    "stiffness_n_per_m",
                    "give the radial `stiffness_n_per_m` or the angular `stiffness_n_m_per_rad`",
                ))
            }
            (Some(_), Some(_)) => return Err(invalid(
                "stiffness_n_m_per_rad",
                "give one spring: radial `stiffness_n_per_m` or angular `stiffness_n_m_per_rad`",
            )),
            _ => {}
        }
        let e = self.knee_offset_m;
        if !(e.is_finite() && e > 0.0) {
            return Err(invalid(
                "knee_offset_m",
                format!("must be finite and positive, got {e}"),
            ));
        }
        if self.knee_side.abs() != 1.0 {
            return Err(invalid(
                "knee_side",
                format!("must be +1 or -1, got {}", self.knee_side),
            ));
        }
        Ok(())
    }

    /// Whether the spring is given radially (`k_r`, `c_r`).
    pub fn is_radial(&self) -> bool {
        self.stiffness_n_per_m.is_some()
    }

    /// The values of [`LEG_STIFFNESS`] and [`LEG_DAMPING`], in the units given.
    pub fn values(&self) -> (f64, f64) {
        if self.is_radial() {
            (
                self.stiffness_n_per_m.unwrap_or(0.0),
                self.damping_n_s_per_m.unwrap_or(0.0),
            )
        } else {
            (
                self.stiffness_n_m_per_rad.unwrap_or(0.0),
                self.damping_n_m_s_per_rad.unwrap_or(0.0),
            )
        }
    }

    /// `(k_θ, c_θ)` at the knee: the angular values, or the radial ones times `e²`.
    pub fn knee_gains(&self) -> (f64, f64) {
        let (k, c) = self.values();
        let w = self.lever_factor();
        (k * w, c * w)
    }

    /// `∂(k_θ, c_θ)/∂(leg_stiffness, leg_damping)`: `e²` for a radial spring, 1 for an
    /// angular one.
    fn lever_factor(&self) -> f64 {
        if self.is_radial() {
            self.knee_offset_m * self.knee_offset_m
        } else {
            1.0
        }
    }
}

/// The knee's geometry of a leg of length `ρ` (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KneeGeometry {
    /// `c = √(ρ² + e²)` (m).
    pub hip_to_knee_m: f64,
    /// `e` (m).
    pub knee_to_toe_m: f64,
    /// `δ₀ = s (π/2 + atan(e/ρ))` (rad): the knee–toe link at right angles to the hip–toe line.
    pub rest_bend_rad: f64,
    /// `β = s atan(e/ρ)` (rad): the hip–toe line's angle from the hip–knee link at rest.
    pub line_offset_rad: f64,
}

impl KneeGeometry {
    pub fn new(leg_length_m: f64, knee_offset_m: f64, knee_side: f64) -> Self {
        let (rho, e) = (leg_length_m, knee_offset_m);
        let a = (e / rho).atan();
        KneeGeometry {
            hip_to_knee_m: rho.hypot(e),
            knee_to_toe_m: e,
            rest_bend_rad: knee_side * (0.5 * std::f64::consts::PI + a),
            line_offset_rad: knee_side * a,
        }
    }

    /// The hip–toe distance at knee bend `δ`: `√(c² + e² + 2 c e cos δ)` (`ρ` at `δ₀`).
    pub fn hip_to_toe_m(&self, bend_rad: f64) -> f64 {
        let (c, e) = (self.hip_to_knee_m, self.knee_to_toe_m);
        (c * c + e * e + 2.0 * c * e * bend_rad.cos()).sqrt()
    }
}

/// Where a compliant leg's coordinates sit: its hip's index in `q` (the knee follows it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CompliantLegIndex {
    pub hip: usize,
    pub geometry: KneeGeometry,
}

/// `robot` with leg `leg` made compliant (module docs): its one link split at the knee, the
/// link's mass, inertia, armature and joint spring on the hip link, its toe contacts (points
/// at the link's tip) on the knee link. Errors name the field.
pub fn compliant_description(
    robot: &RobotDescription,
    leg: &str,
    spec: &CompliantLeg,
) -> Result<(RobotDescription, CompliantLegIndex), SimError> {
    spec.validate()?;
    let i = robot
        .legs
        .iter()
        .position(|l| l.name == leg)
        .ok_or_else(|| SimError::UnknownJoint {
            field: "compliant_leg.legs".into(),
            name: leg.into(),
            known: robot
                .legs
                .iter()
                .map(|l| l.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })?;
    let hip: usize = robot.legs[..i].iter().map(|l| l.links.len()).sum();
    let field = format!("legs[{i}].links");
    let [link] = robot.legs[i].links.as_slice() else {
        return Err(SimError::InvalidValue {
            field,
            reason: "a compliant leg is made of a rigid one-link leg".into(),
        });
    };
    if !link.collision.is_empty() {
        return Err(SimError::InvalidValue {
            field: format!("{field}[0].collision"),
            reason: "a compliant leg's link carries no collision shapes".into(),
        });
    }
    let rho = link.length_m;
    if spec.knee_offset_m >= rho {
        return Err(invalid(
            "knee_offset_m",
            format!(
                "must be shorter than the leg ({rho} m), got {}",
                spec.knee_offset_m
            ),
        ));
    }
    let g = KneeGeometry::new(rho, spec.knee_offset_m, spec.knee_side);
    let massless = link.mass_kg == 0.0 && link.inertia_kg_m2 == 0.0 && link.armature_kg_m2 == 0.0;
    let mut out = robot.clone();
    let mut toes = 0;
    for (k, c) in out.contacts.iter_mut().enumerate() {
        if c.leg.as_deref() != Some(leg) {
            continue;
        }
        let tip =
            matches!(c.shape, ShapeDescription::Point { position_m } if position_m == [0.0, rho]);
        if !tip || c.link.is_some_and(|l| l != 0) {
            return Err(SimError::InvalidValue {
                field: format!("contacts[{k}].shape"),
                reason: format!(
                    "a compliant leg's contact is a point at its link's tip, [0, {rho}] \
                     (the knee bends the link: an arc cannot roll on it)"
                ),
            });
        }
        let slides = !matches!(c.friction, FrictionDescription::Sticking { mu: None, .. });
        if massless && slides {
            return Err(SimError::InvalidValue {
                field: format!("legs[{i}].links[0].mass_kg"),
                reason: "a compliant massless leg cannot slide (two massless joints, one \
                         normal row: Lemma 5.1): give the leg its mass, or a toe that never slips"
                    .into(),
            });
        }
        c.shape = ShapeDescription::Point {
            position_m: [0.0, g.knee_to_toe_m],
        };
        c.link = Some(1);
        toes += 1;
    }
    if toes == 0 {
        return Err(SimError::InvalidValue {
            field: "compliant_leg.legs".into(),
            reason: format!("leg `{leg}` has no toe contact to make compliant"),
        });
    }
    // the link's centre of mass, fixed in the rigid link, in the hip link's frame: the hip
    // link lies at `−β` from the rigid link's line (joint units; world angle `σβ`)
    let sigma = link.axis.sign();
    let com = link.com_m.unwrap_or([0.0, 0.5 * rho]);
    let com = selfmanip_core::frames::rotate(
        sigma * g.line_offset_rad,
        nalgebra::Vector2::new(com[0], com[1]),
    );
    let hip_link = LinkDescription {
        length_m: g.hip_to_knee_m,
        com_m: Some([com.x, com.y]),
        ..link.clone()
    };
    let knee_link = LinkDescription {
        length_m: g.knee_to_toe_m,
        mass_kg: 0.0,
        inertia_kg_m2: 0.0,
        com_m: None,
        axis: link.axis,
        spring: None,
        armature_kg_m2: 0.0,
        collision: Vec::new(),
    };
    out.legs[i].links = vec![hip_link, knee_link];
    Ok((out, CompliantLegIndex { hip, geometry: g }))
}

/// `scenario` with each leg of `legs` made compliant: the robot ([`compliant_description`]),
/// the start state (the hip at the rigid angle less `β`, the knee at rest), the legs'
/// programs (joint `leg` becomes `leg[0]`, its angles shifted by `−β`) and a knee program
/// `leg[1]` with the spring–damper law; the behaviour parameters [`LEG_STIFFNESS`] and
/// [`LEG_DAMPING`] added. Returns each leg's indices (in the order given).
pub fn make_compliant(
    scenario: &mut Scenario,
    legs: &[&str],
    spec: &CompliantLeg,
) -> Result<Vec<CompliantLegIndex>, SimError> {
    spec.validate()?;
    let b = &mut scenario.behaviour;
    for name in [LEG_STIFFNESS, LEG_DAMPING] {
        if b.parameters.contains_key(name) {
            return Err(SimError::InvalidValue {
                field: format!("behaviour.parameters.{name}"),
                reason: "a compliant leg's parameter: the behaviour must not define it".into(),
            });
        }
    }
    let (k, c) = spec.values();
    b.parameters.insert(LEG_STIFFNESS.into(), Scalar::Number(k));
    b.parameters.insert(LEG_DAMPING.into(), Scalar::Number(c));
    let mut out = Vec::with_capacity(legs.len());
    for &leg in legs {
        let (robot, index) = compliant_description(&scenario.robot, leg, spec)?;
        let (hip, beta) = (index.hip, index.geometry.line_offset_rad);
        let initial = &mut scenario.initial;
        if initial.q.len()
            != scenario
                .robot
                .legs
                .iter()
                .map(|l| l.links.len())
                .sum::<usize>()
                + 3
        {
            return Err(SimError::InvalidValue {
                field: "initial.q".into(),
                reason: "one angle per joint and the body's x, z, φ".into(),
            });
        }
        initial.q[hip] -= beta;
        initial.q.insert(hip + 1, index.geometry.rest_bend_rad);
        if let Some(qd) = initial.qd.as_mut() {
            qd.insert(hip + 1, 0.0);
        }
        scenario.robot = robot;
        let b = &mut scenario.behaviour;
        let hip_joint = format!("{leg}[0]");
        for p in b
            .joints
            .iter_mut()
            .filter(|p| p.joint == leg || p.joint == hip_joint)
        {
            p.joint = hip_joint.clone();
            for phase in &mut p.phases {
                shift_phase(phase, beta);
            }
        }
        rename_joint_references(b, leg, &hip_joint);
        b.joints.push(knee_program(leg, spec, &index.geometry));
        out.push(index);
    }
    Ok(out)
}

/// The knee's program: the spring–damper about `δ₀` while the toe is on the ground (a servo
/// whose gains are formulas of [`LEG_STIFFNESS`] and [`LEG_DAMPING`]); in the air the bend
/// the knee left the ground with (the free-joint gains keep the massless knee there).
fn knee_program(leg: &str, spec: &CompliantLeg, g: &KneeGeometry) -> JointProgram {
    let w = spec.lever_factor();
    let gain = |p: &str| {
        if w == 1.0 {
            Scalar::Expr(p.into())
        } else {
            Scalar::Expr(format!("{p} * {w}"))
        }
    };
    JointProgram {
        joint: format!("{leg}[1]"),
        phases: vec![Phase {
            name: "spring".into(),
            start: None,
            torque: Torque::Servo {
                target_rad: Some(Scalar::Number(g.rest_bend_rad)),
                kp_n_m_per_rad: gain(LEG_STIFFNESS),
                kd_n_m_s_per_rad: gain(LEG_DAMPING),
                torque_limit_n_m: None,
                only_in_contact: true,
            },
            motion: Some(Motion::Hold {
                angle_rad: Scalar::Expr("theta".into()),
            }),
            restart_on: Some(vec![Trigger::on(On::Release)]),
        }],
        repeat_from: None,
    }
}

/// An angle of the rigid leg's line as the hip's: `a − β`, where the names of the hip's own
/// angle (`theta`, `q0`) read `(name + β)`.
fn shift_angle(a: &mut Scalar, beta: f64) {
    *a = match a {
        Scalar::Number(x) => Scalar::Number(*x - beta),
        Scalar::Expr(e) => {
            let read = replace_names(e, &["theta", "q0"], &|n| format!("({n} + {beta})"));
            Scalar::Expr(format!("({read}) - {beta}"))
        }
    };
}

/// Every angle of a phase of the hip's program shifted ([`shift_angle`]): its motion's
/// target, its servo's target and a motor's reversal angle.
fn shift_phase(phase: &mut Phase, beta: f64) {
    match &mut phase.motion {
        Some(Motion::Hold { angle_rad: a })
        | Some(Motion::Swing { target_rad: a, .. })
        | Some(Motion::Park { target_rad: a, .. }) => shift_angle(a, beta),
        None => {}
    }
    match &mut phase.torque {
        Torque::Servo {
            target_rad: Some(a),
            ..
        } => shift_angle(a, beta),
        Torque::Motor {
            reverse_beyond_rad: Some(a),
            ..
        } => shift_angle(a, beta),
        _ => {}
    }
}

/// `e` with each whole name of `names` replaced by `with(name)`.
fn replace_names(e: &str, names: &[&str], with: &dyn Fn(&str) -> String) -> String {
    let is_name = |c: char| c.is_alphanumeric() || c == '_' || c == '.';
    let mut out = String::with_capacity(e.len());
    let mut word = String::new();
    let flush = |word: &mut String, out: &mut String| {
        if names.contains(&word.as_str()) {
            out.push_str(&with(word));
        } else {
            out.push_str(word);
        }
        word.clear();
    };
    for ch in e.chars() {
        if is_name(ch) {
            word.push(ch);
        } else {
            flush(&mut word, &mut out);
            out.push(ch);
        }
    }
    flush(&mut word, &mut out);
    out
}

/// Triggers that name the leg's joint (`joint_angle` levels, `phase` references) name its hip.
fn rename_joint_references(b: &mut Behaviour, leg: &str, hip_joint: &str) {
    fn visit(t: &mut Trigger, leg: &str, hip: &str) {
        if t.joint.as_deref() == Some(leg) {
            t.joint = Some(hip.into());
        }
        if let Some(p) = &mut t.phase {
            if let Some(rest) = p.strip_prefix(&format!("{leg}.")) {
                *p = format!("{hip}.{rest}");
            }
        }
        for t in t.any.iter_mut().flatten() {
            visit(t, leg, hip);
        }
    }
    for p in &mut b.joints {
        for phase in &mut p.phases {
            for t in phase
                .start
                .iter_mut()
                .chain(phase.restart_on.iter_mut().flatten())
            {
                visit(t, leg, hip_joint);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use selfmanip_core::kinematics::{Kinematics, Part};

    fn leg_robot(mass: f64) -> RobotDescription {
        RobotDescription::from_toml_str(&format!(
            "name = \"one-leg\"\n[body]\nmass_kg = 7\ninertia_kg_m2 = 0.1\n[[legs]]\nname = \"leg\"\nhip_m = [0.1, 0.0]\n\
             [[legs.links]]\nlength_m = 0.17\nmass_kg = {mass}\ninertia_kg_m2 = {}\naxis = \"-y\"\n\
             [[contacts]]\nname = \"toe\"\nleg = \"leg\"\nshape = {{ kind = \"point\", position_m = [0.0, 0.17] }}\n\
             friction = {{ kind = \"sticking\", mu = 1.0 }}\n",
            0.008 * mass
        ))
        .unwrap()
    }

    /// At rest the compliant leg's toe and centre of mass are the rigid leg's (forward
    /// kinematics of both models), and the hip–toe distance is `ρ`.
    #[test]
    fn rest_pose_is_the_rigid_legs() {
        let rigid = leg_robot(0.126);
        let spec = CompliantLeg::radial(4000.0, 20.0);
        for side in [1.0, -1.0] {
            let spec = CompliantLeg {
                knee_side: side,
                ..spec.clone()
            };
            let (d, idx) = compliant_description(&rigid, "leg", &spec).unwrap();
            let (m0, m1) = (rigid.build().unwrap(), d.build().unwrap());
            let q0 = [0.7, 0.3, -0.2, 0.4];
            let g = idx.geometry;
            let q1 = [0.7 - g.line_offset_rad, g.rest_bend_rad, 0.3, -0.2, 0.4];
            let (mut k0, mut k1) = (Kinematics::default(), Kinematics::default());
            k0.compute(&m0, &q0, &[0.0; 4]);
            k1.compute(&m1, &q1, &[0.0; 5]);
            let toe0 = k0.point(Part::Link(0), nalgebra::Vector2::new(0.0, 0.17));
            let toe1 = k1.point(Part::Link(1), nalgebra::Vector2::new(0.0, 0.05));
            assert!((toe0 - toe1).norm() < 1e-15, "{toe0} vs {toe1}");
            let c0 = k0.point(Part::Link(0), nalgebra::Vector2::new(0.0, 0.085));
            let com = d.legs[0].links[0].com_m.unwrap();
            let c1 = k1.point(Part::Link(0), nalgebra::Vector2::new(com[0], com[1]));
            assert!((c0 - c1).norm() < 1e-15, "{c0} vs {c1}");
            assert!((g.hip_to_toe_m(g.rest_bend_rad) - 0.17).abs() < 1e-15);
        }
    }

    #[test]
    fn bad_input_names_the_field() {
        let field = |s: CompliantLeg| match s.validate() {
            Err(SimError::InvalidValue { field, .. }) => field,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            field(CompliantLeg::radial(-1.0, 0.0)),
            "compliant_leg.stiffness_n_per_m"
        );
        assert_eq!(
            field(CompliantLeg::angular(1.0, f64::NAN)),
            "compliant_leg.damping_n_m_s_per_rad"
        );
        let damping_only = CompliantLeg {
            damping_n_s_per_m: Some(3.0),
            ..CompliantLeg::default()
        };
        assert_eq!(field(damping_only), "compliant_leg.damping_n_s_per_m");
        assert_eq!(
            field(CompliantLeg::default()),
            "compliant_leg.stiffness_n_per_m"
        );
        let both = CompliantLeg {
            stiffness_n_m_per_rad: Some(1.0),
            ..CompliantLeg::radial(1.0, 0.0)
        };
        assert_eq!(field(both), "compliant_leg.stiffness_n_m_per_rad");
        let e = CompliantLeg {
            knee_offset_m: 0.0,
            ..CompliantLeg::radial(1.0, 0.0)
        };
        assert_eq!(field(e), "compliant_leg.knee_offset_m");
        // a massless leg whose toe can slip cannot be compliant (Lemma 5.1)
        let err = compliant_description(&leg_robot(0.0), "leg", &CompliantLeg::radial(1.0, 0.0));
        assert!(
            matches!(&err, Err(SimError::InvalidValue { field, .. }) if field == "legs[0].links[0].mass_kg"),
            "{err:?}"
        );
        let long = CompliantLeg {
            knee_offset_m: 0.2,
            ..CompliantLeg::radial(1.0, 0.0)
        };
        let err = compliant_description(&leg_robot(0.1), "leg", &long);
        assert!(
            matches!(&err, Err(SimError::InvalidValue { field, .. }) if field == "compliant_leg.knee_offset_m"),
            "{err:?}"
        );
    }

    #[test]
    fn names_are_replaced_whole() {
        let s = replace_names(
            "if(s * theta >= 0, 1, -1) * q0 + theta_x",
            &["theta", "q0"],
            &|n| format!("({n} + b)"),
        );
        assert_eq!(s, "if(s * (theta + b) >= 0, 1, -1) * (q0 + b) + theta_x");
    }
}
