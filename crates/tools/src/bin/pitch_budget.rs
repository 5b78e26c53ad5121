//! Where a default leap's pitch comes from: the body's angular momentum about its centre
//! of mass through stance, split by the contact whose ground force makes the moment.
//!
//! ```sh
//! cargo run --release -p selfmanip-tools --bin pitch_budget -- "++" 0
//! ```
//! Arguments: strategy, t2 (s). With massless legs the robot's angular momentum about its
//! COM is the body's, `H = I_b φ̇`, so `I_b φ̈ = Σ_c (r_c − r_G) × λ_c` (NED, pitch about
//! `+y`: `M_y = r_z f_x − r_x f_z`, nose-up positive). The program integrates each contact's
//! moment over every segment (trapezoid on a 20 µs grid), prints the moment's
//! normal and tangential parts, and the jump of `I_b φ̇` at each event (impulses), and
//! checks that the sum reproduces `I_b φ̇` at the apex. `PAIRS=front,rear` chooses the
//! pushing pairs, `M_L=kg` gives the legs Table 4.2's mass (their toes Coulomb unless
//! `FRICTIONLESS`),
//! `BODY_MU` Coulomb friction at the body ends, `STICK=1` point-toe legs, `PINNED=1` toes that never slip, `MU`, `FRICTIONLESS`,
//! `SATURATED`, `CURRENT` (A) and `WAIT` (rad) the other candidates; `SWEEP=1` runs the four
//! 41-point sweeps with these settings instead.
use rhex_model::leap::{leap_params, simulate_leap, GearedMotor, LeapConfig, LegActuator};
use rhex_model::params::{LegPair, ToeSliding};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let strategy = args.get(1).map_or("++", String::as_str);
    let t2: f64 = args.get(2).map_or(Ok(0.0), |s| s.parse())?;
    let pairs = std::env::var("PAIRS").ok().map(|s| {
        let p: Vec<LegPair> = s
            .split(',')
            .map(|n| match n {
                "front" => LegPair::Front,
                "middle" => LegPair::Middle,
                _ => LegPair::Rear,
            })
            .collect();
        [p[0], p[1]]
    });
    let mut cfg = LeapConfig {
        strategy: strategy.parse()?,
        t2_s: t2,
        pairs,
        ..LeapConfig::default()
    };
    if let Ok(v) = std::env::var("WAIT") {
        cfg.wait_clearance_rad = v.parse()?;
    }
    if std::env::var("SATURATED").is_ok() {
        cfg.actuator = LegActuator::SaturatedTorque;
    }
    if let Ok(v) = std::env::var("CURRENT") {
        if let LegActuator::GearedMotor(GearedMotor {
            ref mut current_limit_a,
            ..
        }) = cfg.actuator
        {
            *current_limit_a = v.parse()?;
        }
    }
    let mut params = leap_params();
    if std::env::var("FRICTIONLESS").is_ok() {
        params.toe_sliding = ToeSliding::Frictionless;
    }
    if let Ok(v) = std::env::var("MU") {
        let mu: f64 = v.parse()?;
        params.mu_front = Some(mu);
        params.mu_middle = Some(mu);
        params.mu_rear = Some(mu);
    }
    if let Ok(v) = std::env::var("BODY_MU") {
        // Coulomb friction at the body ends (static = kinetic)
        params.mu_body = Some(v.parse()?);
    }
    if std::env::var("STICK").is_ok() {
        params.leg_shape = rhex_model::params::LegShape::Stick;
    }
    if std::env::var("PINNED").is_ok() {
        params.mu_front = None;
        params.mu_middle = None;
        params.mu_rear = None;
    }
    if let Ok(v) = std::env::var("M_L") {
        // Table 4.2's pair values (m_l = 0.126 kg, I_l = 0.00092 kg m² per pair), the
        // inertia scaled with the mass; the toes keep their sliding law (Coulomb unless
        // FRICTIONLESS: a massive leg's Coulomb toe is folded into the dynamics solve)
        params.m_l = v.parse()?;
        params.I_l = 0.00092 * params.m_l / 0.126;
    }
    if std::env::var("SWEEP").is_ok() {
        // the 41-point default sweep of each strategy with these settings: apex share and
        // the apex pitch at a few t2
        for strategy in rhex_model::leap::Strategy::ALL {
            let mut ok = 0;
            let mut show = String::new();
            // the slowest leap (wall time) and the most level apex
            let mut slowest = (0.0f64, 0.0);
            let mut level: Option<(f64, f64, f64)> = None;
            let mut statuses = std::collections::BTreeMap::<String, usize>::new();
            for k in 0..41 {
                let t2_s = -0.2 + 0.01 * f64::from(k);
                let c = LeapConfig {
                    strategy,
                    t2_s,
                    ..cfg.clone()
                };
                let clock = std::time::Instant::now();
                let r = simulate_leap(&params, &c)?;
                let ms = 1e3 * clock.elapsed().as_secs_f64();
                if ms > slowest.0 {
                    slowest = (ms, t2_s);
                }
                *statuses.entry(r.status.as_str().to_string()).or_default() += 1;
                if let Some(a) = r.apex {
                    if level.is_none_or(|l| a.phi_rad.abs() < l.2.abs()) {
                        level = Some((t2_s, a.z_m, a.phi_rad));
                    }
                    ok += 1;
                    if [-0.1, -0.02, 0.0, 0.1]
                        .iter()
                        .any(|t| (t - t2_s).abs() < 1e-9)
                    {
                        show += &format!(
                            " t2 {:+.2}: {:.1} cm {:+.0} deg;",
                            t2_s,
                            100.0 * a.z_m,
                            a.phi_rad.to_degrees()
                        );
                    }
                }
            }
            println!("  {strategy}: {ok}/41 reach an apex;{show}");
            if let Some((t2, z, phi)) = level {
                println!(
                    "    most level apex: t2 {t2:+.2}: {:.1} cm {:+.1} deg",
                    100.0 * z,
                    phi.to_degrees()
                );
            }
            println!(
                "    statuses {statuses:?}; slowest leap {:.1} ms (t2 {:+.2})",
                slowest.0, slowest.1
            );
        }
        return Ok(());
    }
    let r = simulate_leap(&params, &cfg)?;
    println!(
        "{strategy} t2 = {t2:+.3} s: {} word {}",
        r.status.as_str(),
        r.word_string()
    );
    if r.apex.is_none() {
        println!("  termination {:?}", r.execution.termination);
    }
    if let Some(a) = r.apex {
        println!(
            "  apex t {:.4} s: z {:.3} m, x {:.3} m, pitch {:.1} deg, pitch rate {:.1} deg/s",
            a.t_s,
            a.z_m,
            a.x_m,
            a.phi_rad.to_degrees(),
            a.phidot_rad_s.to_degrees()
        );
    }
    for e in &r.events {
        println!(
            "  event t {:.5} s {:<9} {} -> {} {:?}",
            e.t_s, e.kind, e.mode_before, e.mode_after, e.contacts
        );
    }
    let dt = 2e-5;
    let tr = r.trajectory(dt)?;
    let n = tr.t_s.len();
    let nq = tr.q[0].len();
    let (ix, iz, ip) = (nq - 3, nq - 2, nq - 1);
    let nc = tr.contacts.len();
    let ib = params.I_b;
    // moment of each contact's force about the COM: total, normal part, tangential part
    let moment = |k: usize, c: usize| -> Option<(f64, f64, f64, [f64; 2])> {
        let p = tr.contact_points_m[k][c]?;
        let f = tr.contact_forces_n[k][c]?;
        let (rx, rz) = (p[0] - tr.q[k][ix], p[1] - tr.q[k][iz]);
        // ground normal is -z (flat ground): the force's z part is normal, x tangential
        Some((rz * f[0] - rx * f[1], -rx * f[1], rz * f[0], f))
    };
    let mut per_contact = vec![[0.0f64; 3]; nc];
    // hips of the two pushing legs (contacts 0 and 1), by the pairs the leap used
    let used = cfg.pairs.unwrap_or(cfg.strategy.chapter3_pairs());
    let hip_x: Vec<Option<f64>> = (0..nc)
        .map(|c| (c < 2).then(|| params.hip_x(used[c])))
        .collect();
    // per pushing leg: ∫ moment about its hip (= the reaction of its motor torque on the
    // body for a massless leg), ∫ -f_z (vertical impulse, up), ∫ f_x
    let mut hip_terms = [[0.0f64; 3]; 2];
    let about_hip = |k: usize, c: usize| -> Option<[f64; 3]> {
        let hx = hip_x.get(c).copied().flatten()?;
        let p = tr.contact_points_m[k][c]?;
        let f = tr.contact_forces_n[k][c]?;
        let phi = tr.q[k][ip];
        let h = [tr.q[k][ix] + hx * phi.cos(), tr.q[k][iz] - hx * phi.sin()];
        let (rx, rz) = (p[0] - h[0], p[1] - h[1]);
        Some([rz * f[0] - rx * f[1], -f[1], f[0]])
    };
    let mut phase_rows: Vec<(String, f64, f64, Vec<f64>, f64, f64)> = Vec::new();
    let mut jumps = 0.0;
    for k in 0..n.saturating_sub(1) {
        let h = tr.t_s[k + 1] - tr.t_s[k];
        if h <= 0.0 {
            continue;
        }
        let same_mode = tr.mode[k] == tr.mode[k + 1];
        let mut seg_m = vec![0.0; nc];
        for c in 0..nc {
            if !same_mode {
                continue;
            }
            if let (Some(a), Some(b)) = (moment(k, c), moment(k + 1, c)) {
                per_contact[c][0] += 0.5 * h * (a.0 + b.0);
                per_contact[c][1] += 0.5 * h * (a.1 + b.1);
                per_contact[c][2] += 0.5 * h * (a.2 + b.2);
                seg_m[c] = 0.5 * h * (a.0 + b.0);
            }
            if let (Some(a), Some(b)) = (about_hip(k, c), about_hip(k + 1, c)) {
                for j in 0..3 {
                    hip_terms[c][j] += 0.5 * h * (a[j] + b[j]);
                }
            }
        }
        if !same_mode {
            // an event between the samples: its impulse, and the flow on either side
            // (neglected: under 20 us of flow), from the jump of I_b phidot
            let dh = ib * (tr.qd[k + 1][ip] - tr.qd[k][ip]);
            jumps += dh;
        }
        let label = tr.mode[k].clone();
        match phase_rows.last_mut() {
            Some(row) if row.0 == label => {
                row.2 = tr.t_s[k + 1];
                for (acc, m) in row.3.iter_mut().zip(&seg_m) {
                    *acc += m;
                }
                row.5 = tr.q[k + 1][ip];
            }
            _ => phase_rows.push((
                label,
                tr.t_s[k],
                tr.t_s[k + 1],
                seg_m,
                tr.q[k][ip],
                tr.q[k + 1][ip],
            )),
        }
    }
    println!("  phases (mode, t0..t1, angular impulse about the COM by contact [N m s], pitch at start/end [deg], I_b phidot at end):");
    let mut k_end = 0;
    for row in &phase_rows {
        while k_end + 1 < n && tr.t_s[k_end] < row.2 {
            k_end += 1;
        }
        print!("    {:<6} {:.4}..{:.4}", row.0, row.1, row.2);
        for (c, m) in row.3.iter().enumerate() {
            if *m != 0.0 {
                print!("  {} {:+.4}", tr.contacts[c], m);
            }
        }
        println!(
            "  | phi {:+.1} -> {:+.1}, H {:+.4}",
            row.4.to_degrees(),
            row.5.to_degrees(),
            ib * tr.qd[k_end][ip]
        );
    }
    println!("  angular impulse about the COM over the run, by contact [N m s] (total, normal force's part, tangential force's part):");
    let mut sum = 0.0;
    for (name, pc) in tr.contacts.iter().zip(&per_contact) {
        if pc[0] != 0.0 {
            println!(
                "    {:<12} {:+.4}  ({:+.4} normal, {:+.4} tangential)",
                name, pc[0], pc[1], pc[2]
            );
            sum += pc[0];
        }
    }
    let h_end = ib * tr.qd[n - 1][ip];
    let h0 = ib * tr.qd[0][ip];
    println!(
        "  sum {:+.4} + event jumps {:+.4} = {:+.4}; I_b phidot at end - start: {:+.4} N m s ({:.1} deg/s)",
        sum,
        jumps,
        sum + jumps,
        h_end - h0,
        tr.qd[n - 1][ip].to_degrees()
    );
    for (c, t) in hip_terms.iter().enumerate() {
        println!(
            "  {:<12} motor-torque impulse (moment about its hip) {:+.4} N m s, vertical impulse {:+.3} N s, horizontal {:+.3} N s, hip at x_b = {:+.3} m",
            tr.contacts[c], t[0], t[1], t[2], hip_x[c].unwrap()
        );
    }
    // the pair the leap leaves out (section 3.3: disabled): its hip's lowest height above the
    // ground before the last liftoff, against its height at the start
    if let Some(third) = [LegPair::Front, LegPair::Middle, LegPair::Rear]
        .into_iter()
        .find(|p| !used.contains(p))
    {
        let hx = params.hip_x(third);
        let takeoff = r
            .events
            .iter()
            .filter(|e| e.kind == "liftoff" && e.mode_after == "0000")
            .map(|e| e.t_s)
            .next()
            .unwrap_or(f64::INFINITY);
        let heights: Vec<f64> = (0..n)
            .filter(|&k| tr.t_s[k] <= takeoff)
            .map(|k| -(tr.q[k][iz] - hx * tr.q[k][ip].sin()))
            .collect();
        let lowest = heights.iter().copied().fold(f64::INFINITY, f64::min);
        println!(
            "  disabled {} pair: hip height {:.4} m at the start, lowest {:.4} m before takeoff ({:.4} s)",
            third.name(),
            heights[0],
            lowest,
            takeoff
        );
    }
    let m = params.m_b;
    let zd_up = -tr.qd[n - 1][iz];
    println!(
        "  body: vertical momentum at the end {:+.3} N s (m zdot up), m g over the run {:+.3} N s",
        m * zd_up,
        m * params.g * (tr.t_s[n - 1] - tr.t_s[0])
    );
    if std::env::var("FORCES").is_ok() {
        let every: usize = std::env::var("FORCES").unwrap().parse().unwrap_or(250);
        for k in (0..n).step_by(every) {
            print!(
                "    t {:.4} {:<6} phi {:+6.1} phidot {:+7.1}",
                tr.t_s[k],
                tr.mode[k],
                tr.q[k][ip].to_degrees(),
                tr.qd[k][ip].to_degrees()
            );
            for c in 0..nc {
                if let Some(m) = moment(k, c) {
                    print!(
                        "  {} F ({:+6.1},{:+6.1}) M {:+6.2}",
                        tr.contacts[c], m.3[0], m.3[1], m.0
                    );
                    if let Some(hx) = hip_x.get(c).copied().flatten() {
                        // the hip in the world (NED, nose-up phi lifts points ahead)
                        let phi = tr.q[k][ip];
                        let h = [tr.q[k][ix] + hx * phi.cos(), tr.q[k][iz] - hx * phi.sin()];
                        let p = tr.contact_points_m[k][c].unwrap();
                        let d = [p[0] - h[0], p[1] - h[1]];
                        let r = d[0].hypot(d[1]);
                        let u = [d[0] / r, d[1] / r];
                        print!(
                            " [r {:.3} m, along {:+6.1} N, across {:+6.1} N, qd {:+5.1}]",
                            r,
                            m.3[0] * u[0] + m.3[1] * u[1],
                            m.3[0] * -u[1] + m.3[1] * u[0],
                            tr.qd[k][c.min(1)]
                        );
                    }
                }
            }
            println!();
        }
    }
    Ok(())
}
