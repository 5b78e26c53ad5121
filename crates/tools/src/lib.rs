//! What the probe binaries share: the robot's changes from the environment, the one-line
//! summary of a leap and the line of one of its segments.
use rhex_model::RhexParams;
use selfmanip_hybrid::Segment;

/// Applies the environment's changes to the robot: `ROTORS=1` legs that carry their rotors
/// ([`RhexParams::leg_rotors`]), `M_B` (kg) and `I_B` (kg m²) the body's mass and inertia.
pub fn body_from_env(params: &mut RhexParams) -> Result<(), std::num::ParseFloatError> {
    if std::env::var("ROTORS").is_ok() {
        params.leg_rotors = Some(true);
    }
    if let Ok(v) = std::env::var("M_B") {
        params.m_b = v.parse()?;
    }
    if let Ok(v) = std::env::var("I_B") {
        params.I_b = v.parse()?;
    }
    Ok(())
}

/// Prints `STRATEGY t2=±T s  STATUS word WORD` and, with an apex `(x, z, φ)` (m, m, rad;
/// z up), `  apex x X m, z Z m, pitch P deg`, then ends the line.
pub fn print_leap_line(
    strategy: &str,
    t2_s: f64,
    status: &str,
    word: &str,
    apex: Option<[f64; 3]>,
) {
    print!("{strategy} t2={t2_s:+.3} s  {status:<14} word {word}");
    if let Some([x, z, phi]) = apex {
        print!(
            "  apex x {x:.3} m, z {z:.3} m, pitch {:.1} deg",
            phi.to_degrees()
        );
    }
    println!();
}

/// Prints `{indent}segment T0..T1 BITS N steps`, the segment's times (s), its mode's normal
/// bits and its accepted steps, with ` (locked)` when joints are locked in it.
pub fn print_segment_line(indent: &str, sg: &Segment) {
    println!(
        "{indent}segment {:.6}..{:.6} {:<6} {:>6} steps{}",
        sg.t0,
        sg.t1,
        format!("{:b}", sg.mode.normal_bits()),
        sg.dense.len(),
        if sg.locked.is_empty() {
            ""
        } else {
            " (locked)"
        }
    );
}
