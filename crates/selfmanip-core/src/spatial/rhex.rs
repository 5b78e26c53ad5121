//! RHex with six legs as a spatial robot (issue 32, item 6): thesis Table 4.2's body and
//! legs, three hip pairs at `+ℓ`, `0`, `−ℓ` along the body and `±w` across it, written as a
//! URDF ([`RhexSixLegs::urdf`]) and loaded by the URDF path ([`RhexSixLegs::model`]); and the
//! map between the planar RHex of chapter 4 (`d = 2`, NED) and this robot with each pair's
//! two legs in the pair's state ([`from_planar`], [`acceleration_to_planar`],
//! [`force_to_planar`]).
//!
//! Frames (URDF's, z up): the body frame at the body's centre of mass, `x` forward, `y` to
//! the left, `z` up. Each leg turns about the body's `+y` axis at its hip, so that its angle
//! is the thesis's `θ` (clockwise from the body's down direction seen from the robot's
//! right, Fig. 4.2): at `θ = 0` the leg points down, its toe at `(0, 0, −ρ)` in the leg frame.
//! Names: hip joints `{front,middle,rear}_{left,right}_hip` (in that order, so `v[6..12]`),
//! leg links `…_leg`, the toe frames `…_toe`, the C-leg's arc centre `…_arc` (at `ρ/2` down
//! the leg: the half circle of radius `ρ/2` from hip to toe), and the body's rounded ends
//! `{front,rear}_{left,right}_end` at the front and rear hips (radius `ρ_b` about the hip axis).
#![allow(non_snake_case)]
use super::contact::PointContact;
use super::error::{SpatialError, SpatialResult};
use super::model::{BaseKind, SpatialModel};
use nalgebra::{DVector, Vector3};
use std::fmt::Write;

/// The leg pairs front to rear, and the sides.
pub const PAIRS: [&str; 3] = ["front", "middle", "rear"];
pub const SIDES: [&str; 2] = ["left", "right"];

/// The six-legged RHex's parameters (SI). Table 4.2 gives the planar model's numbers; the
/// spatial robot needs three more, stated here as assumptions (the thesis gives none):
/// the hips' half-width `w` and the body's roll and yaw inertias.
#[derive(Debug, Clone, PartialEq)]
pub struct RhexSixLegs {
    /// `m_b` (Table 4.2: 7.15 kg).
    pub body_mass_kg: f64,
    /// `I_b`, about the body's `y` axis (Table 4.2: 0.15 kg m²).
    pub body_pitch_inertia_kg_m2: f64,
    /// About `x` and `z`: not in the thesis. Defaults from a uniform box of the body's mass,
    /// 0.51 m long (`2(ℓ + ρ_b)`), 0.20 m wide, 0.10 m high: `m(w² + h²)/12 = 0.030` and
    /// `m(l² + w²)/12 = 0.179` kg m².
    pub body_roll_inertia_kg_m2: f64,
    pub body_yaw_inertia_kg_m2: f64,
    /// One leg's mass (Table 4.2: 0.063 kg; the thesis's chapter 4 takes the legs massless,
    /// Assumption C.6, the default here).
    pub leg_mass_kg: f64,
    /// One leg's inertia about its centre of mass and the hip axis (Table 4.2: 0.00046 kg m²;
    /// 0 by default). The leg is a lamina in its plane: half of it about each in-plane axis.
    pub leg_inertia_kg_m2: f64,
    /// `ℓ`, body centre to the front and rear hips (Table 4.2: 0.205 m).
    pub hip_offset_m: f64,
    /// `w`, the hips' half-width across the body: not in the thesis; 0.125 m, the legs just
    /// outside a 0.20 m-wide shell (an assumption; a parameter).
    pub hip_half_width_m: f64,
    /// `ρ`, hip to toe (Table 4.2: 0.17 m).
    pub leg_length_m: f64,
    /// `ρ_b`, the body's rounded ends about the front and rear hips (Table 4.2: 0.05 m).
    pub body_radius_m: f64,
}

impl Default for RhexSixLegs {
    fn default() -> Self {
        Self::table_4_2()
    }
}

impl RhexSixLegs {
    /// Table 4.2 with massless legs (Assumption C.6) and the assumed width and inertias.
    pub fn table_4_2() -> Self {
        let m_b = 7.15;
        let box_inertia = |a: f64, b: f64| m_b * (a * a + b * b) / 12.0;
        Self {
            body_mass_kg: m_b,
            body_pitch_inertia_kg_m2: 0.15,
            body_roll_inertia_kg_m2: box_inertia(0.20, 0.10),
            body_yaw_inertia_kg_m2: box_inertia(0.51, 0.20),
            leg_mass_kg: 0.0,
            leg_inertia_kg_m2: 0.0,
            hip_offset_m: 0.205,
            hip_half_width_m: 0.125,
            leg_length_m: 0.17,
            body_radius_m: 0.05,
        }
    }

    /// `self` with Table 4.2's single leg: 0.063 kg, 0.00046 kg m² (the planar model's pair
    /// is twice this).
    pub fn with_table_4_2_legs(self) -> Self {
        Self {
            leg_mass_kg: 0.063,
            leg_inertia_kg_m2: 0.00046,
            ..self
        }
    }

    /// Every field finite; masses and inertias `≥ 0`, the body's mass and the lengths `> 0`
    /// (the body radius may be 0).
    pub fn validate(&self) -> SpatialResult<()> {
        let fields = [
            ("body_mass_kg", self.body_mass_kg, true),
            (
                "body_pitch_inertia_kg_m2",
                self.body_pitch_inertia_kg_m2,
                false,
            ),
            (
                "body_roll_inertia_kg_m2",
                self.body_roll_inertia_kg_m2,
                false,
            ),
            ("body_yaw_inertia_kg_m2", self.body_yaw_inertia_kg_m2, false),
            ("leg_mass_kg", self.leg_mass_kg, false),
            ("leg_inertia_kg_m2", self.leg_inertia_kg_m2, false),
            ("hip_offset_m", self.hip_offset_m, true),
            ("hip_half_width_m", self.hip_half_width_m, true),
            ("leg_length_m", self.leg_length_m, true),
            ("body_radius_m", self.body_radius_m, false),
        ];
        for (field, x, positive) in fields {
            let ok = x.is_finite() && if positive { x > 0.0 } else { x >= 0.0 };
            if !ok {
                let want = if positive { "positive" } else { "non-negative" };
                return Err(SpatialError::InvalidArgument {
                    field: field.into(),
                    reason: format!("must be finite and {want}, got {x}"),
                });
            }
        }
        Ok(())
    }

    /// The hip of `pair` (0 front, 1 middle, 2 rear) on `side` (0 left, 1 right) in the body
    /// frame.
    pub fn hip_m(&self, pair: usize, side: usize) -> Vector3<f64> {
        let x = [self.hip_offset_m, 0.0, -self.hip_offset_m][pair];
        let y = [self.hip_half_width_m, -self.hip_half_width_m][side];
        Vector3::new(x, y, 0.0)
    }

    /// The robot as URDF text (links and joints as in the module's doc). The hips turn without
    /// end, but are written `revolute` with limits of ±1e6 rad (which nothing here reads): a
    /// `continuous` joint has two coordinates `(cos θ, sin θ)` in Pinocchio's layout and one
    /// here, and the shipped file passes between the two unchanged. The limit's effort is
    /// Table 4.2's `τ_s` = 15 N m.
    pub fn urdf(&self) -> SpatialResult<String> {
        self.validate()?;
        let mut s = String::from("<?xml version=\"1.0\"?>\n<!-- RHex with six legs: thesis Table 4.2, generated by selfmanip_core::spatial::rhex::RhexSixLegs::urdf -->\n<robot name=\"rhex6\">\n");
        let (r, l, w) = (self.leg_length_m, self.hip_offset_m, self.hip_half_width_m);
        link(
            &mut s,
            "body",
            self.body_mass_kg,
            [0.0; 3],
            [
                self.body_roll_inertia_kg_m2,
                self.body_pitch_inertia_kg_m2,
                self.body_yaw_inertia_kg_m2,
            ],
        );
        let i_l = self.leg_inertia_kg_m2;
        for (pair, pair_name) in PAIRS.iter().enumerate() {
            for (side, side_name) in SIDES.iter().enumerate() {
                let name = format!("{pair_name}_{side_name}");
                let hip = self.hip_m(pair, side);
                let leg = format!("{name}_leg");
                link(
                    &mut s,
                    &leg,
                    self.leg_mass_kg,
                    [0.0, 0.0, -0.5 * r],
                    [0.5 * i_l, i_l, 0.5 * i_l],
                );
                let _ = writeln!(
                    s,
                    "  <joint name=\"{name}_hip\" type=\"revolute\"><origin xyz=\"{} {} {}\"/><parent link=\"body\"/><child link=\"{leg}\"/><axis xyz=\"0 1 0\"/><limit lower=\"-1e6\" upper=\"1e6\" effort=\"15\" velocity=\"100\"/></joint>",
                    hip.x, hip.y, hip.z
                );
                for (frame, depth) in [("toe", r), ("arc", 0.5 * r)] {
                    fixed(&mut s, &leg, &format!("{name}_{frame}"), [0.0, 0.0, -depth]);
                }
            }
        }
        for (end, x) in [("front", l), ("rear", -l)] {
            for (side, y) in [("left", w), ("right", -w)] {
                fixed(&mut s, "body", &format!("{end}_{side}_end"), [x, y, 0.0]);
            }
        }
        s.push_str("</robot>\n");
        Ok(s)
    }

    /// The robot with a free-flying body, by the URDF path.
    pub fn model(&self) -> SpatialResult<SpatialModel> {
        self.model_on(BaseKind::FreeFlyer)
    }

    /// The robot with its body attached to the world by `base` (a planar base: the body in
    /// the world's x–z plane, the sagittal plane of the planar model).
    pub fn model_on(&self, base: BaseKind) -> SpatialResult<SpatialModel> {
        SpatialModel::from_urdf_str(&self.urdf()?, base, None)
    }

    /// The toe of leg `name` (`"front_left"`, …) as a point contact on flat ground.
    pub fn toe(
        &self,
        model: &SpatialModel,
        name: &str,
        friction: bool,
    ) -> SpatialResult<PointContact> {
        PointContact::new(model, &format!("{name}_toe"), friction)
    }

    /// The C-leg of `name` rolling on the lowest point of its arc (radius `ρ/2` about `…_arc`,
    /// in the leg's plane, normal to `y`).
    pub fn leg_arc(
        &self,
        model: &SpatialModel,
        name: &str,
        friction: bool,
    ) -> SpatialResult<PointContact> {
        PointContact::new(model, &format!("{name}_arc"), friction)?
            .on_circle(0.5 * self.leg_length_m, Vector3::y())
    }

    /// The C-leg of `name` as the arc it is: the forward half of the circle of
    /// [`Self::leg_arc`], from the toe (angle 0, straight down the leg) through the leg's
    /// front (`π/2`) to the hip (`π`), about the leg's `−y` axis. It rolls on the circle's
    /// lowest point while that lies on the half circle, and otherwise touches at the toe or the
    /// hip end ([`super::contact::ContactShape::Arc`]).
    pub fn leg_c_arc(
        &self,
        model: &SpatialModel,
        name: &str,
        friction: bool,
    ) -> SpatialResult<PointContact> {
        PointContact::new(model, &format!("{name}_arc"), friction)?.on_arc(
            0.5 * self.leg_length_m,
            -Vector3::y(),
            -Vector3::z(),
            (0.0, std::f64::consts::PI),
        )
    }

    /// A rounded body end (`"front_left"`, …) touching on its lowest point (radius `ρ_b`
    /// about the hip axis), frictionless as in the thesis's C.3.
    pub fn body_end(&self, model: &SpatialModel, name: &str) -> SpatialResult<PointContact> {
        PointContact::new(model, &format!("{name}_end"), false)?
            .on_circle(self.body_radius_m, Vector3::y())
    }
}

fn link(s: &mut String, name: &str, mass: f64, com: [f64; 3], inertia: [f64; 3]) {
    let _ = writeln!(
        s,
        "  <link name=\"{name}\"><inertial><origin xyz=\"{} {} {}\"/><mass value=\"{mass}\"/><inertia ixx=\"{}\" ixy=\"0\" ixz=\"0\" iyy=\"{}\" iyz=\"0\" izz=\"{}\"/></inertial></link>",
        com[0], com[1], com[2], inertia[0], inertia[1], inertia[2]
    );
}

/// A massless link `child` fixed to `parent` at `xyz` (a named frame).
fn fixed(s: &mut String, parent: &str, child: &str, xyz: [f64; 3]) {
    link(s, child, 0.0, [0.0; 3], [0.0; 3]);
    let _ = writeln!(
        s,
        "  <joint name=\"{child}_joint\" type=\"fixed\"><origin xyz=\"{} {} {}\"/><parent link=\"{parent}\"/><child link=\"{child}\"/></joint>",
        xyz[0], xyz[1], xyz[2]
    );
}

/// The planar RHex's state as the six-legged robot's, each pair's two legs in the pair's
/// state. The planar model (docs/conventions.md) is NED in the sagittal plane with three
/// pairs: `q = [θ_front, θ_middle, θ_rear, x, z, φ]`, `x` forward, `z` down, `φ` nose-up,
/// `q̇` its time derivative. Here, z up and `y` to the left: the body at `(x, 0, −z)`, turned
/// by `R = R_y(−φ)` (nose-up is a negative turn about the left-pointing `y`), its twist in the
/// body frame `[Rᵀ(ẋ, 0, −ż); (0, −φ̇, 0)]`, each hip at its pair's `θ`, `θ̇` (the same angle:
/// both frames measure it clockwise seen from the right). Returns `(q, v)` (nq 13, nv 12).
pub fn from_planar(q: &[f64], qd: &[f64]) -> SpatialResult<(DVector<f64>, DVector<f64>)> {
    crate::error::check_vector("q", q, 6)?;
    crate::error::check_vector("qd", qd, 6)?;
    let phi = q[5];
    let (s, c) = (0.5 * -phi).sin_cos();
    let mut qs = DVector::zeros(13);
    qs.as_mut_slice()[..7].copy_from_slice(&[q[3], 0.0, -q[4], 0.0, s, 0.0, c]);
    let mut v = DVector::zeros(12);
    let rt = rotation_y(-phi).transpose();
    let lin = rt * Vector3::new(qd[3], 0.0, -qd[4]);
    v.as_mut_slice()[..6].copy_from_slice(&[lin.x, lin.y, lin.z, 0.0, -qd[5], 0.0]);
    for pair in 0..3 {
        for side in 0..2 {
            qs[7 + 2 * pair + side] = q[pair];
            v[6 + 2 * pair + side] = qd[pair];
        }
    }
    Ok((qs, v))
}

fn rotation_y(beta: f64) -> nalgebra::Matrix3<f64> {
    *nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), beta).matrix()
}

/// The planar `q̈` of a spatial acceleration `a` (the derivative of `v`) at a state `(q, v)`
/// of [`from_planar`]'s form: the body's world acceleration `p̈ = R(a_lin + ω × v_lin)`
/// (the body-frame twist's derivative plus the rotation of its axes), `ẍ = p̈_x`,
/// `z̈ = −p̈_z`, `φ̈ = −α_y`; each pair's `θ̈` from its left leg (the right one is returned
/// beside it, for the caller to compare).
pub fn acceleration_to_planar(q: &[f64], v: &[f64], a: &[f64]) -> (DVector<f64>, [f64; 3]) {
    let quat = super::liegroup::quaternion_at(q, 3);
    let r = nalgebra::UnitQuaternion::new_normalize(quat);
    let (lin, w) = (
        Vector3::new(v[0], v[1], v[2]),
        Vector3::new(v[3], v[4], v[5]),
    );
    let p_dd = r * (Vector3::new(a[0], a[1], a[2]) + w.cross(&lin));
    let mut out = DVector::zeros(6);
    let mut right = [0.0; 3];
    for pair in 0..3 {
        out[pair] = a[6 + 2 * pair];
        right[pair] = a[7 + 2 * pair];
    }
    out[3] = p_dd.x;
    out[4] = -p_dd.z;
    out[5] = -a[4];
    (out, right)
}

/// The planar `q̇` of a spatial state `(q, v)` of [`from_planar`]'s form (its inverse on
/// rates): `(ẋ, ż) = (ṗ_x, −ṗ_z)` with `ṗ = R v_lin`, `φ̇ = −ω_y`, each pair's `θ̇` from its
/// left leg.
pub fn velocity_to_planar(q: &[f64], v: &[f64]) -> DVector<f64> {
    let r = nalgebra::UnitQuaternion::new_normalize(super::liegroup::quaternion_at(q, 3));
    let p_dot = r * Vector3::new(v[0], v[1], v[2]);
    let mut out = DVector::zeros(6);
    for pair in 0..3 {
        out[pair] = v[6 + 2 * pair];
    }
    out[3] = p_dot.x;
    out[4] = -p_dot.z;
    out[5] = -v[4];
    out
}

/// A world force (z up) in the planar model's NED sagittal plane: `(f_x, −f_z)`; `f_y` is
/// returned beside it (zero for a state of the plane).
pub fn force_to_planar(f: &Vector3<f64>) -> ([f64; 2], f64) {
    ([f.x, -f.z], f.y)
}
