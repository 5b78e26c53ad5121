//! What the probe binaries share: the one-line summary of a leap.

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
