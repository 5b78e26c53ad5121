//! Stages `contact_set`, `impact`, `complementarity` and `reset` against closed forms: a
//! block landing on a corner (the collision matrix of a rigid body), the rocking block's
//! pivot transfer with and without the pseudo-impulse (5.39)–(5.40), a puck on an incline
//! sticking or slipping at its friction cone (5.19)–(5.20), a three-point landing whose
//! contact set is not unique, and the massless-link tie-break.
mod systems;
use selfmanip_core::{ContactKind, ContactMode, FlatGround, GroundPlane, Model, Terrain};
use selfmanip_hybrid::flow::{Flow, FlowWorkspace};
use selfmanip_hybrid::guard::{Firing, Guard};
use selfmanip_hybrid::reset::{reset, Reset};
use selfmanip_hybrid::reset_workspace::ResetWorkspace;
use selfmanip_hybrid::{ConstantTorque, HybridOptions, Termination, ZeroTorque};
use std::sync::Arc;
use systems::{block, block_inertia, body, one_leg, puck, rotate, Friction, BLOCK, G};

/// Resets `fired` at `(q, q̇)` in `mode` of the flat-ground block world.
fn reset_block(mode: ContactMode, fired: &[Guard], y: &[f64], delta_t_s: f64) -> Reset {
    let model = block(G);
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    let mut ws = FlowWorkspace::new(&model);
    let opts = HybridOptions {
        delta_t_s,
        ..HybridOptions::default()
    };
    let at = Firing {
        guards: fired,
        mode,
        t: 0.0,
        y,
    };
    reset(&mut ws, &mut flow, &opts, at, &[]).unwrap()
}

/// [`ZeroTorque`] for as long as a reset stage may borrow it.
static UNFORCED: ConstantTorque = ZeroTorque;

/// The reset stage of an unforced world (no torque, no pseudo-impulse, nothing barred or
/// held) on `terrain`, with the default fold threshold.
fn unforced_reset<'a>(
    model: &'a Model,
    terrain: &'a dyn Terrain,
    ws: &'a mut FlowWorkspace,
) -> ResetWorkspace<'a> {
    ResetWorkspace {
        model,
        terrain,
        ctrl: &UNFORCED,
        delta_t_s: 0.0,
        ws,
        barred: &[],
        fold_threshold: HybridOptions::default().fold_threshold,
        jammed: Vec::new(),
        held: Vec::new(),
    }
}

/// A tilted block falling at `v` lands on its left corner, which sticks. The impulse `P`
/// (world frame) stops the corner: `K P = −v_c` with the collision matrix
/// `K = I₂/m + u uᵀ/I`, `u = (r_z, −r_x)` for the corner's offset `r` from the centre; then
/// `v⁺ = v⁻ + P/m`, `φ̇⁺ = (r_z P_x − r_x P_z)/I`. The engine's (5.10)/(5.52) must agree.
#[test]
fn block_landing_on_a_corner_matches_the_collision_matrix() {
    let (w, h, m) = BLOCK;
    let inertia = block_inertia(w, h, m);
    let (phi, v) = (0.3_f64, 1.2);
    let r = rotate(phi, [-w / 2.0, h / 2.0]);
    let q = [-r[0], -r[1], phi];
    let y = [q[0], q[1], q[2], 0.0, v, 0.0];
    let out = reset_block(ContactMode::FLIGHT, &[Guard::Touchdown(0)], &y, 0.0);
    let Reset::Continue { event, .. } = out else {
        panic!("{out:?}")
    };
    // K P = −(0, v)
    let u = [r[1], -r[0]];
    let k = [
        [1.0 / m + u[0] * u[0] / inertia, u[0] * u[1] / inertia],
        [u[1] * u[0] / inertia, 1.0 / m + u[1] * u[1] / inertia],
    ];
    let det = k[0][0] * k[1][1] - k[0][1] * k[1][0];
    let p = [
        (k[0][1] * v) / det,  // −(k11·0 − k01·v)/det
        (-k[0][0] * v) / det, // −(k00·v − k10·0)/det
    ];
    let expected = [
        p[0] / m,
        v + p[1] / m,
        (r[1] * p[0] - r[0] * p[1]) / inertia,
    ];
    for (a, b) in event.qd_after.iter().zip(expected) {
        assert!(
            (a - b).abs() < 1e-12,
            "{:?} vs {expected:?}",
            event.qd_after
        );
    }
    assert_eq!(
        event.mode_after,
        ContactMode::parse_names(&block(G), "left").unwrap()
    );
    // the impact takes energy, never adds it
    assert!(event.kinetic_after < event.kinetic_before);
}

/// The rocking block of section 5.1.4: level, pivoting on its left corner at `ω < 0`, its
/// right corner strikes the ground. Both corners stopped would need the normal impulses
/// `P_Lz + P_Rz = −m v_z`, `(w/2)(P_Lz − P_Rz) = −ω (I + m h²/4)` (momentum about the
/// centre; pushing is negative): the left one pulls, `P_Lz = ω m (w² − 2h²) / (6w) > 0`.
/// Without the pseudo-impulse the left corner lets go and the block pivots on the right
/// one with `ω⁺ = ω (I + m (h² − w²)/4) / (I + m (w² + h²)/4)` (angular momentum about the
/// new corner). With δt the left corner is judged by `P_Lz + P_δ,z`, `P_δ,z = −m g δt / 2`
/// (5.39)–(5.40): it stays when that pushes.
#[test]
fn rocking_block_pivot_transfer_follows_rule_5_40() {
    let (w, h, m) = BLOCK;
    let inertia = block_inertia(w, h, m);
    let model = block(G);
    let left = ContactMode::parse_names(&model, "left").unwrap();
    let both = [Guard::Touchdown(1)];
    for (omega, delta_t) in [(-1.0_f64, 0.0), (-1.0, 0.03), (-3.0, 0.03)] {
        // rotating about the left corner (−w/2, h/2): v = −ω (h/2, w/2)
        let y = [
            0.0,
            -h / 2.0,
            0.0,
            -omega * h / 2.0,
            -omega * w / 2.0,
            omega,
        ];
        let p_left = omega * m * (w * w - 2.0 * h * h) / (6.0 * w);
        assert!(p_left > 0.0, "the left corner's own impulse pulls");
        let keeps_left = p_left - m * G * delta_t / 2.0 <= 0.0;
        let Reset::Continue { event, .. } = reset_block(left, &both, &y, delta_t) else {
            panic!("no reset")
        };
        assert_eq!(
            event.mode_after.contains(0),
            keeps_left,
            "ω {omega}, δt {delta_t}"
        );
        assert!(event.mode_after.contains(1));
        let omega_plus = if keeps_left {
            0.0
        } else {
            omega * (inertia + m * (h * h - w * w) / 4.0) / (inertia + m * (w * w + h * h) / 4.0)
        };
        assert!(
            (event.qd_after[2] - omega_plus).abs() < 1e-12,
            "ω⁺ {:?}",
            event.qd_after
        );
    }
}

/// A puck at rest on an incline of slope β: its sticking force is the weight's
/// components, `λ_n = −m g cos β` (pushing) and `|λ_t| = m g sin β`; complementarity keeps
/// it sticking while `tan β ≤ μ` (the Coulomb cone), and makes it slide beyond.
#[test]
fn puck_on_an_incline_sticks_inside_the_cone_and_slides_outside() {
    let mu = 0.5_f64;
    for beta in [0.3_f64, 0.6] {
        let model = puck(mu);
        let plane = GroundPlane {
            point_m: [0.0, 0.0],
            normal_into_ground: [beta.sin(), beta.cos()],
        };
        let stick = ContactMode::parse_names(&model, "foot").unwrap();
        let mut ws = FlowWorkspace::new(&model);
        let mut cx = unforced_reset(&model, &plane, &mut ws);
        let q = [0.0, 0.0, beta];
        let selected = cx
            .select(0.0, &[0], &[], stick, &q, &[0.0; 3], false)
            .unwrap()
            .unwrap();
        if beta.tan() <= mu {
            assert_eq!(selected.mode.kind(0), Some(ContactKind::Stick));
            assert!((selected.value[0].abs() - 2.0 * G * beta.sin()).abs() < 1e-9);
            assert!((selected.value[1] + 2.0 * G * beta.cos()).abs() < 1e-9);
        } else {
            assert_eq!(selected.mode.kind(0), Some(ContactKind::Slide));
            assert!((selected.value[0] + 2.0 * G * beta.cos()).abs() < 1e-9);
        }
    }
}

/// Three collinear frictionless points landing flat: any two of them stop the body, and the
/// third one's row is dependent on theirs (its set with it is singular), so every pair
/// satisfies complementarity and the event ends as several solutions, naming the pairs.
#[test]
fn three_point_landing_has_several_contact_solutions() {
    let model = body(
        1.0,
        0.01,
        G,
        &[
            ("a", -0.1, 0.05, Friction::Slide),
            ("b", 0.0, 0.05, Friction::Slide),
            ("c", 0.1, 0.05, Friction::Slide),
        ],
    );
    let mut flow = Flow::new(&model, &FlatGround, Arc::new(ZeroTorque));
    let mut ws = FlowWorkspace::new(&model);
    let fired = [
        Guard::Touchdown(0),
        Guard::Touchdown(1),
        Guard::Touchdown(2),
    ];
    let y = [0.0, -0.05, 0.0, 0.0, 1.0, 0.0];
    let at = Firing {
        guards: &fired,
        mode: ContactMode::FLIGHT,
        t: 0.2,
        y: &y,
    };
    let out = reset(&mut ws, &mut flow, &HybridOptions::default(), at, &[]).unwrap();
    let pair = |s| ContactMode::parse_names(&model, s).unwrap();
    assert_eq!(
        out,
        Reset::End {
            event: None,
            termination: Termination::SeveralContactSolutions {
                t: 0.2,
                candidates: vec![pair("a,b"), pair("a,c"), pair("b,c")],
            }
        }
    );
}

/// A sticking toe that touches down now and would pull slides instead, on a massless link
/// and (issue 16: a pulling impulse is outside the friction cone whatever the link's mass;
/// released, a massive toe kept its approach speed and touched down again at once) on a
/// massive one; a contact held before, a pushing one and a sliding one do not.
#[test]
fn toe_touching_down_slides_instead_of_pulling() {
    for (link_mass, expected) in [(0.0, Some(0)), (0.4, Some(0))] {
        let model = one_leg(0.2, link_mass, G);
        let mut ws = FlowWorkspace::new(&model);
        let cx = unforced_reset(&model, &FlatGround, &mut ws);
        let toe = ContactMode::parse_names(&model, "toe").unwrap();
        let toe_sliding = ContactMode::parse_names(&model, "toe:slide").unwrap();
        let pull = [(0, -1.0)];
        assert_eq!(cx.touchdown_pull(toe, ContactMode::FLIGHT, &pull), expected);
        assert_eq!(cx.touchdown_pull(toe, toe, &pull), None, "held before");
        assert_eq!(
            cx.touchdown_pull(toe, ContactMode::FLIGHT, &[(0, 1.0)]),
            None
        );
        assert_eq!(
            cx.touchdown_pull(toe_sliding, ContactMode::FLIGHT, &pull),
            None
        );
    }
}
