//! Zeno truncation (`selfmanip_hybrid::zeno::truncate`): a run whose transitions accumulate
//! goes on in the mode the pseudo-impulse (5.39)–(5.40) converges to, reported as an event,
//! instead of stopping. The rocking block of Figs. 5.4–5.5 with a pseudo-impulse far below
//! its truncating size (δt = 1e-9 s: the threshold of (5.44) is 2e-9 m/s, so it rocks on until
//! the Zeno window fires) is the closed-form case: the truncation is the plastic impact into
//! both corners, which fixes a rigid block entirely — at rest on the ground, all its kinetic
//! energy lost in that event.
use selfmanip_core::{ContactMode, Model};
use selfmanip_hybrid::zeno::ZenoWindow;
use selfmanip_hybrid::{EventKind, HybridOptions, Termination};

mod systems;
use systems::{released, BLOCK, G};

const H: f64 = BLOCK.1;
const W: f64 = BLOCK.0;
const M: f64 = 5.0;

fn tilted_on_left_corner(model: &Model, phi: f64) -> ([f64; 3], ContactMode) {
    let (s, c) = phi.sin_cos();
    let (cx, cz) = (-W / 2.0, H / 2.0);
    let q = [-(c * cx + s * cz), -(-s * cx + c * cz), phi];
    (q, ContactMode::parse_names(model, "left").unwrap())
}

#[test]
fn rocking_block_zeno_is_truncated_at_rest_on_both_corners() {
    let model = systems::block(G);
    let (q, mode) = tilted_on_left_corner(&model, 0.15);
    let opts = HybridOptions {
        delta_t_s: 1e-9,
        ..Default::default()
    };
    let exec = released(&model, mode, &q, 2.0, opts);
    assert_eq!(
        exec.termination,
        Termination::FinalTime,
        "{:?}",
        exec.termination
    );
    let truncations: Vec<_> = exec
        .events
        .iter()
        .filter(|e| e.kind == EventKind::ZenoTruncation)
        .collect();
    assert_eq!(truncations.len(), 1, "{:?}", exec.events.last());
    let z = truncations[0];
    assert_eq!(z.triggered, vec![0, 1], "names both corners");
    assert_eq!(z.mode_after.active().collect::<Vec<_>>(), vec![0, 1]);
    // it came after more than `zeno_max_events` impacts within one window, the last event
    assert!(exec.events.len() > opts.zeno_max_events);
    assert!(
        std::ptr::eq(z, exec.events.last().unwrap()),
        "nothing after it"
    );
    // two corners held fix the planar block: q̇⁺ = 0, the whole kinetic energy lost
    assert!(
        z.qd_after.iter().all(|v| v.abs() < 1e-12),
        "{:?}",
        z.qd_after
    );
    assert!(z.kinetic_after.abs() < 1e-15);
    assert!(z.kinetic_before > 0.0);
    // … on the ground, level to the rocking's amplitude at the accumulation (the corner it
    // adds is within TERRAIN_STEP_M of the ground): the centre at h/2 (NED z = −h/2)
    assert!(
        (exec.q[1] + H / 2.0).abs() < 1e-7 && exec.q[2].abs() < 1e-6,
        "{:?}",
        exec.q
    );
    assert!(exec.qd.iter().all(|v| v.abs() < 1e-9));
    // energy: the potential drop from the start to the end, at rest, equals the impact
    // losses (gravity is the only force that works)
    let drop = M * G * (exec.q[1] - q[1]);
    let lost: f64 = exec.impact_losses().iter().sum();
    assert!(
        (drop - lost).abs() < 1e-9 * drop.max(1.0),
        "drop {drop} lost {lost}"
    );
}

/// A truncation that the next Zeno window finds less than one window back made no progress:
/// that window may not be truncated again (the run then ends `Zeno`); one more than a window
/// later it may.
#[test]
fn a_truncation_that_recurs_within_one_window_is_refused() {
    let (w, n) = (0.01, 50);
    let mut zeno = ZenoWindow::new(w, n);
    assert!(zeno.may_truncate(0.0));
    let d = w / (2.0 * n as f64);
    let fired = (0..=n).find_map(|k| zeno.record(k as f64 * d, &[k % 2]));
    let t1 = n as f64 * d;
    assert!(matches!(fired, Some(Termination::Zeno { .. })));
    zeno.truncated(t1);
    // the window starts afresh: n more transitions are allowed
    let again = (1..=n).find_map(|k| zeno.record(t1 + k as f64 * d, &[0]));
    assert!(again.is_none());
    let t2 = t1 + (n + 1) as f64 * d;
    assert!(zeno.record(t2, &[0]).is_some());
    assert!(
        !zeno.may_truncate(t2),
        "within one window of the truncation"
    );
    assert!(zeno.may_truncate(t1 + 1.01 * w));
}
