//! The linear DC motor: voltage rescaling laws, the energy balance of the actuator, and
//! typed errors.
use approx::assert_relative_eq;
use motor::{Actuator, Catalog, DcMotor, Drive, MotorError, SaturatedTorque};

fn x_rhex_18() -> Drive {
    Catalog::thesis().drive("x-rhex-18").unwrap()
}

#[test]
fn rescaling_the_supply_voltage_scales_speed_and_stall_torque_not_the_thermal_limit() {
    let m = x_rhex_18().motor;
    let half = m.at_voltage(0.5 * m.supply_voltage_v).unwrap();
    assert_relative_eq!(
        half.no_load_speed_rad_s,
        0.5 * m.no_load_speed_rad_s,
        max_relative = 1e-15
    );
    assert_relative_eq!(
        half.stall_torque_n_m,
        0.5 * m.stall_torque_n_m,
        max_relative = 1e-15
    );
    assert_eq!(half.continuous_torque_n_m, m.continuous_torque_n_m);
    // the resistance is a property of the winding, independent of the supply
    assert_relative_eq!(
        half.terminal_resistance_ohm(),
        m.terminal_resistance_ohm(),
        max_relative = 1e-14
    );
    // peak power scales with V² when the current limit does not bind
    let free = m.with_current_limit(1e9).unwrap();
    let double = free.at_voltage(2.0 * m.supply_voltage_v).unwrap();
    assert_relative_eq!(
        double.peak_power_w(),
        4.0 * free.peak_power_w(),
        max_relative = 1e-14
    );
    // and back
    let back = half.at_voltage(m.supply_voltage_v).unwrap();
    assert_relative_eq!(
        back.stall_torque_n_m,
        m.stall_torque_n_m,
        max_relative = 1e-15
    );
}

#[test]
fn supply_power_equals_mechanical_power_plus_copper_friction_and_gear_losses() {
    // P_el = V_eff I with V_eff = R I + k_e ω (k_e = V/ω₀), and τ_m = k_M I, so
    //   P_el − τ_m ω_m = I² R + (k_e − k_M) I ω_m.
    // The second term is the no-load (friction) loss: Table 2.1's X-RHex motor has
    // k_e = 37 V / 10314 rpm = 34.3 mNm/A against k_M = 670 mNm / 20 A = 33.5 mNm/A.
    // The output sees η τ_m: P_el − τ_out ω_out ≥ 0 whenever the motor is motoring.
    let drive = x_rhex_18();
    let m = &drive.motor;
    let g = drive.gearbox.ratio;
    let k_e = m.supply_voltage_v / m.no_load_speed_rad_s;
    assert!(k_e > m.torque_constant_n_m_per_a);
    for &u in &[1.0, 0.7, 0.3, -0.5] {
        for &w_out in &[0.0, 5.0, 20.0, 50.0, -10.0] {
            let tau_out = drive.joint_torque_n_m(u, w_out);
            let w_m = w_out * g;
            let tau_m = m.torque_n_m(u, w_m);
            let current = m.current_for_torque_a(tau_m);
            let p_el = drive.electrical_power_w(u, w_out);
            let losses = current * current * m.terminal_resistance_ohm()
                + (k_e - m.torque_constant_n_m_per_a) * current * w_m;
            assert_relative_eq!(
                p_el - tau_m * w_m,
                losses,
                epsilon = 1e-9,
                max_relative = 1e-12
            );
            if tau_m * w_out >= 0.0 {
                assert!(p_el - tau_out * w_out >= -1e-9);
            }
        }
    }
}

#[test]
fn current_limit_clips_the_torque_and_the_saturated_actuator_clips_the_command() {
    let m = x_rhex_18().motor.with_current_limit(9.0).unwrap();
    assert_relative_eq!(
        m.max_torque_at_speed_n_m(0.0),
        9.0 * m.torque_constant_n_m_per_a
    );
    assert!(m.torque_n_m(1.0, 10.0 * m.no_load_speed_rad_s) >= -m.current_limited_torque_n_m());
    let s = SaturatedTorque::new(2.0).unwrap();
    assert_eq!(s.joint_torque_n_m(3.0, 0.0), 2.0);
    assert_eq!(s.joint_torque_n_m(-0.25, 7.0), -0.5);
    assert_eq!(s.electrical_power_w(-0.25, 4.0), -2.0);
}

#[test]
fn bad_motor_parameters_are_typed_errors() {
    assert!(matches!(
        DcMotor::new(24.0, 1000.0, -0.1, 0.02, 10.0, 0.02),
        Err(MotorError::InvalidParameter {
            field: "stall_torque_n_m",
            ..
        })
    ));
    assert!(matches!(
        DcMotor::new(f64::NAN, 1000.0, 0.1, 0.02, 10.0, 0.02),
        Err(MotorError::InvalidParameter {
            field: "supply_voltage_v",
            ..
        })
    ));
    let mut gearbox = x_rhex_18().gearbox;
    gearbox.ratio = 0.0;
    assert!(matches!(
        Drive::new(x_rhex_18().motor, gearbox.clone()),
        Err(MotorError::InvalidParameter { field: "ratio", .. })
    ));
    gearbox.ratio = 18.0;
    gearbox.efficiency = 1.2;
    assert!(matches!(
        Drive::new(x_rhex_18().motor, gearbox),
        Err(MotorError::InvalidParameter {
            field: "efficiency",
            ..
        })
    ));
    assert!(matches!(
        SaturatedTorque::new(0.0),
        Err(MotorError::InvalidParameter { .. })
    ));
}
