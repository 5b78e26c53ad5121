//! Kinematic queries for any robot at any `(q, q̇)`: the pose and velocity of the body and
//! of every link, the contact points with their velocities, gaps and Jacobians, and the
//! Jacobian of any material point. Checked entry points over [`Kinematics`] and
//! [`contact_geometry`]; positions are world `(x, z)` (NED: z down), angles about `+y`.
use crate::contact::{contact_geometry, Terrain};
use crate::error::{check_vector, Result};
use crate::kinematics::{Kinematics, Part};
use crate::model::Model;
use nalgebra::{DMatrix, Vector2};
use serde::Serialize;

/// Pose and velocity of one rigid part.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PartState {
    /// Origin of the part's frame: the body's centre of mass, or a link's joint.
    pub position_m: [f64; 2],
    /// World angle about `+y` (`φ` for the body, `β_j = φ + Σ s_k θ_k` for link `j`).
    pub angle_rad: f64,
    pub velocity_m_s: [f64; 2],
    pub angular_velocity_rad_s: f64,
}

/// Forward kinematics of every part.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Poses {
    pub body: PartState,
    /// Link `j` (the link joint `j` drives), its frame at joint `j`.
    pub links: Vec<PartState>,
    /// World position of each link's far end (the next joint, or the leg's tip).
    pub link_ends_m: Vec<[f64; 2]>,
}

fn arr(v: Vector2<f64>) -> [f64; 2] {
    [v.x, v.y]
}

fn kinematics(model: &Model, q: &[f64], qd: &[f64]) -> Result<Kinematics> {
    check_vector("q", q, model.nq())?;
    check_vector("qd", qd, model.nq())?;
    let mut kin = Kinematics::default();
    kin.compute(model, q, qd);
    kin.check_finite()?;
    Ok(kin)
}

/// The pose and velocity of the body and of every link at `(q, q̇)`.
pub fn forward_kinematics(model: &Model, q: &[f64], qd: &[f64]) -> Result<Poses> {
    let kin = kinematics(model, q, qd)?;
    let state = |part: Part| PartState {
        position_m: arr(kin.part_origin(part)),
        angle_rad: kin.part_angle(part),
        velocity_m_s: arr(match part {
            Part::Body => kin.body_vel,
            Part::Link(j) => kin.origin_vel[j],
        }),
        angular_velocity_rad_s: kin.part_angle_rate(part),
    };
    Ok(Poses {
        body: state(Part::Body),
        links: (0..model.n_joints())
            .map(|j| state(Part::Link(j)))
            .collect(),
        link_ends_m: (0..model.n_joints())
            .map(|j| arr(kin.point(Part::Link(j), Vector2::new(0.0, model.joints[j].length_m))))
            .collect(),
    })
}

/// The 2×nq Jacobian `∂p/∂q` of the material point at `local_m` in `part`'s frame (rows:
/// world x, z), so that its velocity is `J q̇`; and its world position.
pub fn point_jacobian(
    model: &Model,
    q: &[f64],
    part: Part,
    local_m: [f64; 2],
) -> Result<(DMatrix<f64>, [f64; 2])> {
    if let Part::Link(j) = part {
        if j >= model.n_joints() {
            return Err(crate::CoreError::WrongLength {
                field: "part",
                expected: model.n_joints(),
                actual: j,
            });
        }
    }
    crate::error::check_finite("local_m", &local_m)?;
    let kin = kinematics(model, q, &vec![0.0; model.nq()])?;
    let p = kin.point(part, Vector2::new(local_m[0], local_m[1]));
    Ok((kin.point_jacobian(model, part, p), arr(p)))
}

/// One contact site against the terrain at `(q, q̇)`.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactPoint {
    pub name: String,
    /// The point of the site nearest the terrain feature it would touch (world).
    pub position_m: [f64; 2],
    /// The velocity of the robot's material point there, `J q̇`.
    pub velocity_m_s: [f64; 2],
    /// Height above that feature (negative: penetrating).
    pub gap_m: f64,
    /// The feature's normal, into the ground.
    pub normal_into_ground: [f64; 2],
    /// 2×nq Jacobian of the material point at `position_m`.
    pub jacobian: DMatrix<f64>,
}

/// Every contact site of `model` against `terrain` at `(q, q̇)`.
pub fn contact_points(
    model: &Model,
    terrain: &dyn Terrain,
    q: &[f64],
    qd: &[f64],
) -> Result<Vec<ContactPoint>> {
    let kin = kinematics(model, q, qd)?;
    Ok((0..model.n_contacts())
        .map(|k| {
            let g = contact_geometry(model, &kin, terrain, k);
            ContactPoint {
                name: model.contacts[k].name.clone(),
                position_m: arr(g.point),
                velocity_m_s: arr(kin.material_velocity(g.part, g.point)),
                gap_m: g.gap_m,
                normal_into_ground: g.plane.normal_into_ground,
                jacobian: kin.point_jacobian(model, g.part, g.point),
            }
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::FlatGround;
    use crate::RobotDescription;

    /// `tests/data/robots/knee_and_wheel_feet.toml`.
    fn robot() -> Model {
        let text = include_str!("../../../tests/data/robots/knee_and_wheel_feet.toml");
        RobotDescription::from_toml_str(text)
            .unwrap()
            .build()
            .unwrap()
    }

    const Q: [f64; 6] = [0.4, -0.9, 1.1, 0.3, -0.5, 0.2];
    const QD: [f64; 6] = [1.3, -2.0, 0.7, 0.4, -0.3, 1.5];

    /// Chains close: each link ends where the next begins; the first starts at its hip,
    /// `X + R(φ) h`; the body's state is `q`'s.
    #[test]
    fn links_chain_from_the_hips() {
        let m = robot();
        let p = forward_kinematics(&m, &Q, &QD).unwrap();
        assert_eq!(p.body.position_m, [Q[3], Q[4]]);
        assert_eq!(
            (p.body.angle_rad, p.body.angular_velocity_rad_s),
            (Q[5], QD[5])
        );
        assert!((p.links[1].position_m[0] - p.link_ends_m[0][0]).abs() < 1e-15);
        let (s, c) = Q[5].sin_cos();
        let hip = [Q[3] + c * 0.2 + s * 0.03, Q[4] - s * 0.2 + c * 0.03];
        assert!((p.links[0].position_m[0] - hip[0]).abs() < 1e-15);
        assert!((p.links[0].position_m[1] - hip[1]).abs() < 1e-15);
        // link angles: φ + Σ s θ (the knee turns about −y)
        assert!((p.links[1].angle_rad - (Q[5] + Q[0] - Q[1])).abs() < 1e-15);
        assert!((p.links[1].angular_velocity_rad_s - (QD[5] + QD[0] - QD[1])).abs() < 1e-15);
    }

    /// Jacobians against central differences of the positions; velocities against
    /// differences along q̇.
    #[test]
    fn jacobians_and_velocities_match_finite_differences() {
        let m = robot();
        let h = 1e-6;
        let (j, _) = point_jacobian(&m, &Q, Part::Link(1), [0.02, 0.1]).unwrap();
        for k in 0..m.nq() {
            let (mut qp, mut qm) = (Q, Q);
            qp[k] += h;
            qm[k] -= h;
            let pp = point_jacobian(&m, &qp, Part::Link(1), [0.02, 0.1])
                .unwrap()
                .1;
            let pm = point_jacobian(&m, &qm, Part::Link(1), [0.02, 0.1])
                .unwrap()
                .1;
            for r in 0..2 {
                assert!(
                    (j[(r, k)] - (pp[r] - pm[r]) / (2.0 * h)).abs() < 1e-8,
                    "({r}, {k})"
                );
            }
        }
        let cps = contact_points(&m, &FlatGround, &Q, &QD).unwrap();
        let shift = |s: f64| -> Vec<f64> { Q.iter().zip(&QD).map(|(q, v)| q + s * v).collect() };
        for (k, cp) in cps.iter().enumerate() {
            // the material point at the contact, moved along q̇
            let local = {
                let kin = kinematics(&m, &Q, &QD).unwrap();
                let part = match m.contacts[k].link {
                    None => Part::Body,
                    Some(l) => Part::Link(l),
                };
                let (s, c) = kin.part_sin_cos(part);
                let d = Vector2::new(cp.position_m[0], cp.position_m[1]) - kin.part_origin(part);
                (part, [c * d.x - s * d.y, s * d.x + c * d.y])
            };
            let at = |q: &[f64]| point_jacobian(&m, q, local.0, local.1).unwrap().1;
            let (pp, pm) = (at(&shift(h)), at(&shift(-h)));
            for r in 0..2 {
                let fd = (pp[r] - pm[r]) / (2.0 * h);
                assert!((cp.velocity_m_s[r] - fd).abs() < 1e-7, "{} {r}", cp.name);
                let jv: f64 = (0..m.nq()).map(|c| cp.jacobian[(r, c)] * QD[c]).sum();
                assert!((cp.velocity_m_s[r] - jv).abs() < 1e-12);
            }
            // on flat ground the gap is the height above z = 0 (z down)
            assert!((cp.gap_m + cp.position_m[1]).abs() < 1e-15, "{}", cp.name);
        }
        assert!(matches!(
            forward_kinematics(&m, &Q[..5], &QD),
            Err(crate::CoreError::WrongLength { field: "q", .. })
        ));
    }
}
