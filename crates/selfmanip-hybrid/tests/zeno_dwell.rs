//! The Zeno window and the truncation's dwell (`selfmanip_hybrid::zeno::ZenoWindow`) on the
//! transition times of a bouncing ball, whose Zeno execution is known in closed form: with
//! restitution `e` the flights last `τ_k = τ₀ eᵏ` and the impacts accumulate at
//! `t_∞ = t₀ + τ₀ / (1 − e)`. The window fires at the first impact `k` whose last
//! `zeno_max_events` flights fit in one window, `τ_{k−N} (1 − e^N)/(1 − e) < W`, before
//! `t_∞`; a cycle that resumes after every dwell has its dwells double, so that a horizon `T`
//! holds at most `⌊log2(T/W + 1)⌋ + 1` truncations in a row.
use selfmanip_hybrid::zeno::ZenoWindow;
use selfmanip_hybrid::Termination;

/// The impact times `t_k = t₀ + τ₀ (1 − eᵏ)/(1 − e)` of a ball with restitution `e`.
fn impact_time(t0: f64, tau0: f64, e: f64, k: usize) -> f64 {
    t0 + tau0 * (1.0 - e.powi(k as i32)) / (1.0 - e)
}

#[test]
fn bouncing_ball_zeno_window_fires_at_the_closed_form_impact_before_the_accumulation() {
    let (w, n) = (0.01, 50);
    for &(tau0, e) in &[(0.2, 0.9), (0.05, 0.8), (0.5, 0.95)] {
        let t0 = 0.1;
        let mut zeno = ZenoWindow::new(w, n);
        let fired = (0..100_000)
            .find(|&k| zeno.record(impact_time(t0, tau0, e, k), &[0]).is_some())
            .expect("the window fires");
        // closed form: the smallest k ≥ N with t_k − t_{k−N} < W (the window is open on the
        // left: an impact exactly W back is outside it)
        let expected = (n..)
            .find(|&k| tau0 * e.powi((k - n) as i32) * (1.0 - e.powi(n as i32)) / (1.0 - e) < w)
            .unwrap();
        assert_eq!(fired, expected, "tau0 {tau0} e {e}");
        let t_inf = t0 + tau0 / (1.0 - e);
        assert!(impact_time(t0, tau0, e, fired) < t_inf);
    }
}

#[test]
fn a_cycle_resuming_after_every_dwell_makes_logarithmically_many_truncations() {
    let (w, n) = (0.01, 50);
    let d = w / (2.0 * n as f64); // the cycle's transitions: two per rest time
    for &horizon in &[0.05, 0.5, 10.0] {
        let mut zeno = ZenoWindow::new(w, n);
        let (mut t, mut truncations, mut dwells) = (0.0, 0usize, Vec::new());
        while t < horizon {
            t += d;
            if let Some(Termination::Zeno { .. }) = zeno.record(t, &[0]) {
                let dwell = zeno.dwell_s(w);
                zeno.truncated(t, dwell);
                dwells.push(dwell);
                truncations += 1;
                t += dwell; // the held mode, then the cycle resumes at once
            }
        }
        // each dwell doubles the last: w, 2w, 4w, …
        for (i, &dw) in dwells.iter().enumerate() {
            assert_eq!(dw, w * 2f64.powi(i as i32));
        }
        let bound = (horizon / w + 1.0).log2().floor() as usize + 1;
        assert!(
            truncations <= bound,
            "T = {horizon}: {truncations} truncations, bound {bound}"
        );
    }
}
