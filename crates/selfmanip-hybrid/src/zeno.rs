//! Zeno detection: a run that makes more than `zeno_max_events` transitions — events, and
//! passages of a contact onto the next terrain feature — within any window of
//! `zeno_window_s` stops with [`Termination::Zeno`]. An execution of the thesis's hybrid
//! system is non-Zeno when its massless limbs move with bounded acceleration (section
//! 5.2); a rocking block without the pseudo-impulse is the classic Zeno execution, its
//! impacts accumulating at a finite time (section 5.1.4). Feature passages count as well:
//! a site rocking across the boundary between two features could otherwise split the flow
//! without end.
use crate::execution::Termination;

/// The times of the transitions so far, latest last.
#[derive(Debug, Clone)]
pub struct ZenoWindow {
    window_s: f64,
    max_in_window: usize,
    times: Vec<f64>,
}

impl ZenoWindow {
    pub fn new(window_s: f64, max_in_window: usize) -> Self {
        ZenoWindow {
            window_s,
            max_in_window,
            times: Vec::new(),
        }
    }

    /// Records a transition at `t` (not before the last one); `Zeno` if the window ending
    /// at `t` now holds more than the allowed number.
    pub fn record(&mut self, t: f64) -> Option<Termination> {
        self.times.push(t);
        let since = t - self.window_s;
        let in_window = self.times.iter().rev().take_while(|&&s| s > since).count();
        (in_window > self.max_in_window).then_some(Termination::Zeno {
            t,
            events_in_window: in_window,
        })
    }
}
