//! Prints the constants of eq. (2.1) from the derivation in `motor::tail`, and ranks a
//! synthetic 1,546-motor catalog on the section-2.1.1 tail task.
use motor::catalog::synthetic_motors;
use motor::tail::{rank_tail_motors, tail_constants, SelectionConstraints, TailTask};

fn main() {
    let k = tail_constants();
    println!(
        "s* = {:.6}, k_omega = {:.6}, k_t = {:.6}",
        k.s_star, k.k_omega, k.k_t
    );
    let task = TailTask::new(std::f64::consts::FRAC_PI_2, 0.05, 1.29).expect("valid task");
    let motors = synthetic_motors(1546, 7).expect("1,546 motors are within the bound");
    let constraints = SelectionConstraints {
        max_length_m: 0.030,
        max_mass_kg: 0.200,
        max_completion_time_s: 0.5,
    };
    let selection = rank_tail_motors(&motors, &task, &constraints).expect("non-empty catalog");
    println!(
        "{} of {} motors feasible; fastest three:",
        selection.ranked.len(),
        motors.len()
    );
    for r in selection.ranked.iter().take(3) {
        println!(
            "  {:>16}  P = {:6.1} W  G = {:6.1}  t = {:.3} s",
            r.name, r.peak_power_w, r.gear_ratio, r.completion_time_s
        );
    }
}
