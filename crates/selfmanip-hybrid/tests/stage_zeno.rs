//! Stage `zeno`: the windowed transition counter against its closed form (the rocking
//! block's Zeno execution of section 5.1.4 is stopped by it in `executions.rs`).
use selfmanip_hybrid::zeno::ZenoWindow;
use selfmanip_hybrid::Termination;

/// Transitions every `d` seconds: a window of `w` holds `⌈w/d⌉` of them once full, so with
/// at most `n` allowed it fires at the `(n+1)`-th transition exactly when `n·d < w`, and
/// never when `n·d ≥ w`.
#[test]
fn window_fires_at_the_closed_form_transition() {
    let (w, n) = (0.01, 50);
    for d in [1e-4, 1.9e-4, 2.1e-4, 1e-3] {
        let mut zeno = ZenoWindow::new(w, n);
        let fired = (0..500).find_map(|k| zeno.record(k as f64 * d, &[k % 2]).map(|z| (k, z)));
        if (n as f64) * d < w {
            let (k, z) = fired.expect("Zeno");
            assert_eq!(k, n, "d = {d}");
            assert_eq!(
                z,
                Termination::Zeno {
                    t: n as f64 * d,
                    events_in_window: n + 1,
                    contacts: vec![0, 1],
                }
            );
        } else {
            assert!(fired.is_none(), "d = {d}: {fired:?}");
        }
    }
}
