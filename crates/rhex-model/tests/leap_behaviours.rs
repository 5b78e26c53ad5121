//! The four shipped leap behaviour files, run by the behaviour interpreter of
//! `selfmanip-sim`, against the leap controller they describe (`rhex_model::leap`): a second
//! formulation of the same open-loop strategy (section 3.2.1), which must give the same
//! executions — same statuses, words, events (times, kinds, modes, contacts, impulses,
//! energies, states) and apexes, bit for bit — over a t2 grid in all four strategies, with
//! both actuators, stopped at the apex and run on to the landings, on flat ground and at a
//! ledge, with a toe stub and with legs that keep pushing after liftoff.
//!
//! Run before the old controller is replaced: when the leap physics changes, the controller
//! and the files change together and this test says whether they still agree.
use rhex_model::leap::{leap_params, simulate_leap, LeapConfig, LegActuator, Strategy};
use rhex_model::leap_behaviours::{leap_behaviour, leap_scenario};
use selfmanip_sim::terrain::TerrainSpec;
use selfmanip_sim::Simulation;

/// Runs one configuration both ways and compares everything; returns the word.
fn same_leap(cfg: &LeapConfig) -> String {
    let params = leap_params();
    let r = match simulate_leap(&params, cfg) {
        Ok(r) => r,
        Err(e) => {
            // an engine failure (a step too small): the interpreter must meet it too, at the
            // same place
            let q0 = start_pose(cfg);
            let ls = leap_scenario(&params, cfg, &q0).unwrap();
            let err = Simulation::new(&ls.scenario).unwrap().run().unwrap_err();
            assert_eq!(
                format!("{e:?}"),
                format!("{:?}", rhex_model::RhexError::from(err))
            );
            return format!("error: {e}");
        }
    };
    let ls = leap_scenario(&params, cfg, &r.q0).unwrap();
    let run = Simulation::new(&ls.scenario).unwrap().run().unwrap();
    let (a, b) = (&r.execution, &run.execution);
    let what = format!("{} t2 {} {:?}", cfg.strategy, cfg.t2_s, cfg.actuator);
    assert_eq!(a.termination, b.termination, "{what}");
    // bit for bit (`{:?}` prints each float's shortest round-trip form: equal text, equal
    // bits, NaN included — the kinetic energy of an apex event is NaN)
    assert_eq!(
        format!("{:?}", a.events),
        format!("{:?}", b.events),
        "{what}: events"
    );
    assert_eq!(a.segments.len(), b.segments.len(), "{what}: segments");
    for (sa, sb) in a.segments.iter().zip(&b.segments) {
        assert_eq!((sa.mode, sa.t0, sa.t1), (sb.mode, sb.t0, sb.t1), "{what}");
        assert_eq!(sa.y0, sb.y0, "{what}");
    }
    assert_eq!(
        (a.t, &a.q, &a.qd, a.mode),
        (b.t, &b.q, &b.qd, b.mode),
        "{what}"
    );
    assert_eq!(r.word, run.outcome.word, "{what}: word");
    // the apex as the leap reports it (z up, from the start, front leg's clock)
    let apex_sim = run.outcome.apex.map(|s| {
        (
            s.t_s - ls.time_offset_s,
            s.x_m - r.q0[2],
            -s.z_m,
            s.phi_rad,
            s.xdot_m_s,
            -s.zdot_m_s,
            s.phidot_rad_s,
        )
    });
    let apex_leap = r.apex.map(|a| {
        (
            a.t_s,
            a.x_m,
            a.z_m,
            a.phi_rad,
            a.xdot_m_s,
            a.zdot_m_s,
            a.phidot_rad_s,
        )
    });
    assert_eq!(apex_leap, apex_sim, "{what}: apex");
    assert_eq!(ls.time_offset_s, r.time_offset_s);
    r.word_string()
}

/// The start pose of a leap whose run fails: that of the same leap stopped at once.
fn start_pose(cfg: &LeapConfig) -> Vec<f64> {
    let short = LeapConfig {
        t_final_s: cfg.t2_s.abs() + 1e-3,
        ..cfg.clone()
    };
    simulate_leap(&leap_params(), &short).unwrap().q0
}

fn t2_grid() -> Vec<f64> {
    (0..21).map(|i| -0.2 + 0.02 * i as f64).collect()
}

#[test]
fn the_behaviour_files_give_the_controllers_leaps_to_apex() {
    let mut words = std::collections::BTreeSet::new();
    for strategy in Strategy::ALL {
        for actuator in [LegActuator::default(), LegActuator::SaturatedTorque] {
            for &t2 in &t2_grid() {
                let cfg = LeapConfig {
                    strategy,
                    t2_s: t2,
                    actuator: actuator.clone(),
                    ..LeapConfig::default()
                };
                words.insert(same_leap(&cfg));
            }
        }
    }
    // the comparison covers many different leaps, not one repeated
    assert!(words.len() > 20, "{} distinct words", words.len());
}

#[test]
fn the_behaviour_files_give_the_controllers_landings_ledges_stubs_and_pushes() {
    let ledge = TerrainSpec::Ledge {
        height_m: 0.2,
        distance_m: 0.45,
    };
    for strategy in Strategy::ALL {
        for t2 in [-0.1, -0.04, 0.0, 0.03, 0.1] {
            let base = LeapConfig {
                strategy,
                t2_s: t2,
                ..LeapConfig::default()
            };
            for cfg in [
                LeapConfig {
                    stop_at_apex: false,
                    ..base.clone()
                },
                LeapConfig {
                    stop_at_apex: false,
                    terrain: ledge,
                    t_final_s: 1.2,
                    ..base.clone()
                },
                LeapConfig {
                    toe_stub_rad: Some(0.6),
                    ..base.clone()
                },
                LeapConfig {
                    keep_pushing_after_liftoff: true,
                    stop_at_apex: false,
                    ..base.clone()
                },
            ] {
                same_leap(&cfg);
            }
        }
    }
}

/// The files are well-formed data: each parses, names its strategy, and pushes in the
/// strategy's directions.
#[test]
fn each_file_is_its_strategy() {
    for s in Strategy::ALL {
        let b = leap_behaviour(s);
        assert_eq!(b.name, format!("rhex-leap-{s}"));
        let sign = |k: &str| match &b.parameters[k] {
            selfmanip_sim::expr::Scalar::Number(x) => *x,
            other => panic!("{other:?}"),
        };
        assert_eq!(
            (sign("s_front"), sign("s_rear")),
            (s.front.sign(), s.rear.sign())
        );
    }
}
