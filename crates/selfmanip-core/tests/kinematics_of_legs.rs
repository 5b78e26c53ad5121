//! The kinematics of selected legs (`Kinematics::compute_legs`, what the guards' samples
//! compute) against the whole robot's (`Kinematics::compute`): the same poses, velocities
//! and contact gaps, bit for bit, on the legs computed; the other legs left as they were.
mod common;
use common::test_robot;
use proptest::prelude::*;
use selfmanip_core::contact::contact_gap;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::{FlatGround, Model};

fn model() -> Model {
    test_robot("knee_and_wheel_feet.toml").build().unwrap()
}

/// `(origin, origin velocity, angle, angle rate)` of joint `j`, as bits.
fn pose_bits(kin: &Kinematics, j: usize) -> [u64; 6] {
    [
        kin.origin[j].x,
        kin.origin[j].y,
        kin.origin_vel[j].x,
        kin.origin_vel[j].y,
        kin.beta[j],
        kin.beta_dot[j],
    ]
    .map(f64::to_bits)
}

proptest! {
    #[test]
    fn selected_legs_match_the_whole_robot_and_the_others_stay(
        y in prop::collection::vec(-3.0..3.0f64, 16),
        stale in prop::collection::vec(-3.0..3.0f64, 16),
        legs in 0u64..4,
    ) {
        let m = model();
        let nq = m.nq();
        let (q, qd) = (&y[..nq], &y[nq..2 * nq]);
        let mut whole = Kinematics::default();
        whole.compute(&m, q, qd);
        // the partial kinematics start from another state: what they do not compute keeps it
        let mut part = Kinematics::default();
        part.compute(&m, &stale[..nq], &stale[nq..2 * nq]);
        let before = part.clone();
        part.compute_legs(&m, q, qd, legs);
        prop_assert_eq!(part.body_pos, whole.body_pos);
        prop_assert_eq!(part.body_vel, whole.body_vel);
        for (j, joint) in m.joints.iter().enumerate() {
            let expected = if legs >> joint.leg & 1 == 1 { &whole } else { &before };
            prop_assert_eq!(pose_bits(&part, j), pose_bits(expected, j), "joint {}", j);
        }
        let ground = FlatGround;
        for (k, contact) in m.contacts.iter().enumerate() {
            let on_computed = contact.link.is_none_or(|j| legs >> m.joints[j].leg & 1 == 1);
            if on_computed {
                let (a, b) = (contact_gap(&m, &part, &ground, k), contact_gap(&m, &whole, &ground, k));
                prop_assert_eq!(a.to_bits(), b.to_bits(), "contact {}", k);
            }
        }
    }
}
