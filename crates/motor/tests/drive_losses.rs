//! The drive's optional losses ([`DriveLosses`]): off, every output is the plain linear
//! model's bit for bit; the gearbox loss by power flow and the battery's internal resistance
//! against their closed forms; the energy balance with both losses, term by term.
use approx::assert_relative_eq;
use motor::{Actuator, Catalog, Drive, DriveLosses, GearboxLoss, MotorError};

/// X-RHex's motor behind the 28:1 gearbox (η = 0.82 in the catalog).
fn x_rhex_28() -> Drive {
    Catalog::thesis().drive("x-rhex-28").unwrap()
}

fn with(drive: &Drive, gearbox_loss: GearboxLoss, battery_resistance_ohm: f64) -> Drive {
    drive
        .with_losses(DriveLosses {
            gearbox_loss,
            battery_resistance_ohm,
        })
        .unwrap()
}

/// `(G, η, R, k_e)` of a drive: ratio, efficiency, terminal resistance and back-EMF constant.
fn constants(d: &Drive) -> (f64, f64, f64, f64) {
    let m = &d.motor;
    (
        d.gearbox.ratio,
        d.gearbox.efficiency,
        m.terminal_resistance_ohm(),
        m.supply_voltage_v / m.no_load_speed_rad_s,
    )
}

const COMMANDS: [f64; 5] = [1.0, 0.6, 0.2, -0.4, -1.0];
/// Output speeds (rad/s) on both sides of standstill, up to past the no-load speed (≈ 38 rad/s).
const SPEEDS: [f64; 7] = [-20.0, -3.0, 0.0, 4.0, 15.0, 30.0, 45.0];

/// The linear model written out: `G η τ_stall (u − G ω/ω₀)` clipped at `G η k_M I_max`.
fn plain_output_torque(d: &Drive, u: f64, w_out: f64) -> f64 {
    let m = &d.motor;
    let limit = m.torque_constant_n_m_per_a * m.current_limit_a;
    let tau_m = (m.stall_torque_n_m * (u - w_out * d.gearbox.ratio / m.no_load_speed_rad_s))
        .clamp(-limit, limit);
    d.gearbox.ratio * d.gearbox.efficiency * tau_m
}

#[test]
fn default_losses_keep_the_plain_model_bit_for_bit_and_power_flow_at_eta_1_is_the_derating() {
    let d = x_rhex_28();
    assert_eq!(d.losses, DriveLosses::default());
    let explicit = with(&d, GearboxLoss::Derating, 0.0);
    let mut ideal_gear = d.gearbox.clone();
    ideal_gear.efficiency = 1.0;
    let lossless = Drive::new(d.motor.clone(), ideal_gear).unwrap();
    let lossless_flow = with(&lossless, GearboxLoss::PowerFlow, 0.0);
    for u in COMMANDS {
        for w in SPEEDS {
            let plain = plain_output_torque(&d, u, w);
            assert_eq!(
                d.joint_torque_n_m(u, w).to_bits(),
                plain.to_bits(),
                "u={u} w={w}"
            );
            assert_eq!(explicit.joint_torque_n_m(u, w).to_bits(), plain.to_bits());
            assert_eq!(
                explicit.electrical_power_w(u, w).to_bits(),
                d.electrical_power_w(u, w).to_bits()
            );
            assert_eq!(
                lossless_flow.joint_torque_n_m(u, w).to_bits(),
                lossless.joint_torque_n_m(u, w).to_bits()
            );
        }
    }
}

#[test]
fn power_flow_loss_is_g_eta_tau_when_driving_and_g_tau_over_eta_when_back_driven() {
    let d = x_rhex_28();
    let flow = with(&d, GearboxLoss::PowerFlow, 0.0);
    let (g, eta) = (d.gearbox.ratio, d.gearbox.efficiency);
    let m = &d.motor;
    // driving (standstill included)
    for (u, w_out) in [(1.0, 20.0), (0.5, 5.0), (-0.5, -5.0), (1.0, 0.0)] {
        let tau_m = m.torque_n_m(u, w_out * g);
        assert!(tau_m * w_out >= 0.0);
        assert_relative_eq!(
            flow.joint_torque_n_m(u, w_out),
            g * eta * tau_m,
            max_relative = 1e-15
        );
    }
    // back-driven: the leg turned backwards against a forward command, and the motor braking
    // a leg that runs faster than its no-load speed
    for (u, w_out) in [(1.0, -3.0), (0.3, 20.0), (-0.6, 10.0)] {
        let tau_m = m.torque_n_m(u, w_out * g);
        assert!(tau_m * w_out < 0.0, "u={u} w={w_out}");
        assert_relative_eq!(
            flow.joint_torque_n_m(u, w_out),
            g * tau_m / eta,
            max_relative = 1e-15
        );
        // the derating would transmit less braking torque than the motor's own
        assert!(d.joint_torque_n_m(u, w_out).abs() < flow.joint_torque_n_m(u, w_out).abs());
    }
    // at standstill the torque jumps by η² between a slow backwards and a slow forward turn
    let tiny = 1e-9;
    let ratio = flow.joint_torque_n_m(1.0, tiny) / flow.joint_torque_n_m(1.0, -tiny);
    assert_relative_eq!(ratio, eta * eta, max_relative = 1e-6);
}

#[test]
fn battery_resistance_lowers_the_stall_torque_to_k_m_v_over_r_plus_r_b_not_the_no_load_speed() {
    let d = x_rhex_28();
    // without a binding current limit: the unclipped line
    let free = Drive::new(d.motor.with_current_limit(1e6).unwrap(), d.gearbox.clone()).unwrap();
    let m = &free.motor;
    let (g, eta, r, k_e) = constants(&free);
    for r_b in [0.05, 0.3, 2.0] {
        let b = with(&free, GearboxLoss::Derating, r_b);
        let stall = g * eta * m.torque_constant_n_m_per_a * m.supply_voltage_v / (r + r_b);
        assert_relative_eq!(b.joint_torque_n_m(1.0, 0.0), stall, max_relative = 1e-14);
        assert!(b.joint_torque_n_m(1.0, m.no_load_speed_rad_s / g).abs() < 1e-12);
        // partial command: the winding current solves u (V_oc − R_b u I) = R I + k_e ω
        for (u, w_out) in [(0.5, 3.0), (0.8, 10.0), (-0.7, 2.0)] {
            let w_m = w_out * g;
            let current = b.joint_torque_n_m(u, w_out) / (g * eta * m.torque_constant_n_m_per_a);
            let terminal_v = m.supply_voltage_v - r_b * u * current;
            assert_relative_eq!(
                u * terminal_v,
                r * current + k_e * w_m,
                max_relative = 1e-12
            );
            // the battery current is u I (a lossless PWM stage)
            let p_m = (r * current + k_e * w_m) * current;
            assert_relative_eq!(b.battery_current_a(p_m), u * current, max_relative = 1e-10);
        }
    }
    // with the 20 A limit: the smaller of the limit and the battery's stall current
    // (Table 2.1's motor stalls at about the limit, so any R_b lowers it; a 100 A limit stays)
    for (limit_a, r_b) in [(20.0, 0.05), (100.0, 0.05), (20.0, 1.0)] {
        let limited = Drive::new(
            d.motor.with_current_limit(limit_a).unwrap(),
            d.gearbox.clone(),
        )
        .unwrap();
        let b = with(&limited, GearboxLoss::Derating, r_b);
        let stall_a = m.supply_voltage_v / (r + r_b);
        let expected = g * eta * m.torque_constant_n_m_per_a * stall_a.min(limit_a);
        assert_relative_eq!(b.joint_torque_n_m(1.0, 0.0), expected, max_relative = 1e-14);
    }
}

#[test]
fn battery_energy_equals_output_work_plus_copper_friction_gear_and_battery_losses() {
    // P_el = τ_out ω_out + R I² + (k_e − k_M) I ω_m + P_gear + R_b I_b², each term from its own
    // formula: P_gear = (1 − η) τ_m ω_m driving, (1/η − 1) |τ_m ω_m| back-driven (≥ 0)
    let d = x_rhex_28();
    let m = &d.motor;
    let (g, eta, r, k_e) = constants(&d);
    for r_b in [0.0, 0.1, 0.5] {
        let flow = with(&d, GearboxLoss::PowerFlow, r_b);
        for u in COMMANDS {
            for w_out in SPEEDS {
                let w_m = w_out * g;
                let tau_m = m.torque_on_battery_n_m(u, w_m, r_b);
                let current = tau_m / m.torque_constant_n_m_per_a;
                let p_gear = if tau_m * w_m >= 0.0 {
                    (1.0 - eta) * tau_m * w_m
                } else {
                    (1.0 / eta - 1.0) * (tau_m * w_m).abs()
                };
                assert!(p_gear >= 0.0);
                let p_m = (r * current + k_e * w_m) * current;
                let i_b = flow.battery_current_a(p_m);
                assert_relative_eq!(
                    (m.supply_voltage_v - r_b * i_b) * i_b,
                    p_m,
                    epsilon = 1e-9,
                    max_relative = 1e-12
                );
                let balance = flow.joint_torque_n_m(u, w_out) * w_out
                    + r * current * current
                    + (k_e - m.torque_constant_n_m_per_a) * current * w_m
                    + p_gear
                    + r_b * i_b * i_b;
                assert_relative_eq!(
                    flow.electrical_power_w(u, w_out),
                    balance,
                    epsilon = 1e-9,
                    max_relative = 1e-12
                );
            }
        }
    }
    // the derating, back-driven, hands back more power at the output than the motor absorbs
    let (u, w_out) = (1.0, -3.0);
    let tau_m = m.torque_n_m(u, w_out * g);
    assert!(d.joint_torque_n_m(u, w_out) * w_out - tau_m * w_out * g > 0.0);
}

#[test]
fn a_negative_or_non_finite_battery_resistance_is_a_typed_error() {
    let d = x_rhex_28();
    for bad in [-0.1, f64::NAN, f64::INFINITY] {
        let e = d
            .with_losses(DriveLosses {
                gearbox_loss: GearboxLoss::PowerFlow,
                battery_resistance_ohm: bad,
            })
            .unwrap_err();
        assert!(
            matches!(
                e,
                MotorError::InvalidParameter {
                    field: "battery_resistance_ohm",
                    ..
                }
            ),
            "{e:?}"
        );
    }
    // the losses read from a description: defaults for absent fields, unknown ones refused
    let l: DriveLosses = serde_json::from_str(r#"{"gearbox_loss": "power_flow"}"#).unwrap();
    assert_eq!(l.gearbox_loss, GearboxLoss::PowerFlow);
    assert_eq!(l.battery_resistance_ohm, 0.0);
    assert!(serde_json::from_str::<DriveLosses>(r#"{"efficiency": 0.7}"#).is_err());
}
