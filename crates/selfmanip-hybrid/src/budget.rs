//! Bounded work per run: a budget of integration steps and of events
//! ([`crate::HybridOptions::max_steps`], [`crate::HybridOptions::max_events`]), and a flag
//! by which the caller stops a run from outside (another thread, a Ctrl-C handler). A run
//! that exhausts a budget or is stopped ends with a typed [`Termination`] and keeps what it
//! has computed: no input can make one run take unbounded time or memory (every accepted
//! step is kept in the dense output).
//!
//! The flag is read once per accepted step (a relaxed atomic load: free next to a step's
//! seven flow evaluations), so a run stops within one step of it being raised.
use crate::execution::Termination;
use std::sync::atomic::{AtomicBool, Ordering};

/// A flag that is never raised: the stop flag of [`crate::simulate()`].
pub static NEVER: AtomicBool = AtomicBool::new(false);

/// The work a run may still do, and the flag that stops it.
#[derive(Debug)]
pub struct Budget<'a> {
    max_steps: usize,
    steps: usize,
    stop: &'a AtomicBool,
}

impl<'a> Budget<'a> {
    pub fn new(max_steps: usize, stop: &'a AtomicBool) -> Self {
        Budget {
            max_steps,
            steps: 0,
            stop,
        }
    }

    /// Accepted steps so far.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Counts one accepted step ending at `t`: the termination if the run must end there
    /// (stopped from outside, or out of steps).
    pub fn step(&mut self, t: f64) -> Option<Termination> {
        self.steps += 1;
        if self.stopped() {
            return Some(Termination::Interrupted { t });
        }
        (self.steps >= self.max_steps).then_some(Termination::StepBudget {
            t,
            steps: self.steps,
        })
    }

    /// Counts one accepted step that ends in an event (the run goes on to its reset).
    pub fn count(&mut self) {
        self.steps += 1;
    }

    /// Whether the stop flag is raised.
    pub fn stopped(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The budget ends the run at its last step, not one later; a raised flag ends it at the
    /// next step whatever the budget.
    #[test]
    fn steps_and_stop_flag() {
        let flag = AtomicBool::new(false);
        let mut b = Budget::new(3, &flag);
        assert_eq!(b.step(0.1), None);
        assert_eq!(b.step(0.2), None);
        assert_eq!(
            b.step(0.3),
            Some(Termination::StepBudget { t: 0.3, steps: 3 })
        );
        let mut b = Budget::new(usize::MAX, &flag);
        assert_eq!(b.step(0.1), None);
        flag.store(true, Ordering::Relaxed);
        assert_eq!(b.step(0.2), Some(Termination::Interrupted { t: 0.2 }));
        assert!(!NEVER.load(Ordering::Relaxed));
    }
}
