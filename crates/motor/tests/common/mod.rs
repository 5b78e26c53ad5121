//! Fixtures shared by the motor crate's tests and the motor benchmark (which includes this
//! file by path).
use motor::observer::ObserverParams;

/// The leg of the synthetic observer logs: motor gain and pole, the leg controller's gains,
/// gravity pulling the leg towards θ = 0 (straight down) and a 12 ms delay.
pub fn synthetic_leg() -> ObserverParams {
    ObserverParams {
        k_m: 50.0,
        a_m: 20.0,
        k_p: 10.0,
        k_d: 0.5,
        k_g: -1.0,
        theta_g_rad: 0.0,
        delay_s: 0.012,
    }
}
