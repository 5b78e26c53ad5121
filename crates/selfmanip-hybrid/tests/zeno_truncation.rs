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

/// A truncation holds its mode for one window; one that the next Zeno window fires without
/// a quiet window since the last dwell's end (the cycle resumed: no progress) holds twice as
/// long, and a truncation after a quiet window starts again from one window.
#[test]
fn a_truncation_that_recurs_without_a_quiet_window_dwells_twice_as_long() {
    let (w, n) = (0.01, 50);
    let mut zeno = ZenoWindow::new(w, n);
    let d = w / (2.0 * n as f64);
    let fired = (0..=n).find_map(|k| zeno.record(k as f64 * d, &[k % 2]));
    let t1 = n as f64 * d;
    assert!(matches!(fired, Some(Termination::Zeno { .. })));
    assert_eq!(zeno.dwell_s(w), w, "the first dwell is one window");
    zeno.truncated(t1, w);
    // the window starts afresh: n more transitions are allowed after the dwell, here spread
    // so that the next window fires more than one window after the dwell's end
    let t_end = t1 + w;
    let slow = 0.9 * w / n as f64;
    let start = t_end + 0.5 * w;
    let again = (0..n).find_map(|k| zeno.record(start + k as f64 * slow, &[0]));
    assert!(again.is_none());
    let t2 = start + n as f64 * slow;
    assert!(zeno.record(t2, &[0]).is_some());
    assert!(t2 - t_end > w);
    assert_eq!(
        zeno.dwell_s(w),
        2.0 * w,
        "no quiet window since the dwell's end"
    );
    zeno.truncated(t2, 2.0 * w);
    // a transition a quiet window after the dwell's end: the next dwell is one window
    assert!(zeno.record(t2 + 2.0 * w + 1.01 * w, &[0]).is_none());
    assert_eq!(zeno.dwell_s(w), w, "after a quiet window");
}
