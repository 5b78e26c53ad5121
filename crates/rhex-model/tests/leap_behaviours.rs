//! The four shipped leap behaviour files (`data/behaviours/leap_{pp,pm,mp,mm}.toml`), the
//! data `rhex_model::leap::simulate_leap` runs through the behaviour interpreter of
//! `selfmanip-sim`. That those leaps are the ones the former hand-written leap controller
//! gave, bit for bit, is the engine corpus's check (`scripts/engine-corpus.sh` against a
//! corpus made with that controller); here, that each file is its strategy.
use rhex_model::leap::{leap_behaviour, Strategy, LEAP_BEHAVIOURS};
use selfmanip_sim::Behaviour;

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

/// Each file drives its strategy's chapter-3 pairs (section 3.3: the leading leg disabled):
/// the front-most pushing pair's program first, each waiting, then pushing with its motor in
/// its sign from its start time, then retracting.
#[test]
fn each_file_drives_its_strategys_pairs() {
    use selfmanip_sim::behaviour::{Torque, Trigger};
    for (symbols, text) in LEAP_BEHAVIOURS {
        let strategy: Strategy = symbols.parse().unwrap();
        let b = Behaviour::from_toml_str(text).unwrap();
        let pairs = strategy.chapter3_pairs();
        for (prog, (pair, (start, sign))) in b.joints.iter().zip(
            pairs
                .iter()
                .zip([("t_front", "s_front"), ("t_rear", "s_rear")]),
        ) {
            assert_eq!(prog.joint, pair.name(), "{symbols}");
            let names: Vec<&str> = prog.phases.iter().map(|p| p.name.as_str()).collect();
            assert_eq!(names, ["wait", "push", "retract"], "{symbols}");
            let push = &prog.phases[1];
            assert_eq!(push.start, Some(Trigger::at(start)), "{symbols}");
            match &push.torque {
                Torque::Motor { command, .. } => assert_eq!(*command, sign.into(), "{symbols}"),
                other => panic!("{symbols}: {other:?}"),
            }
        }
    }
}

/// The files are the documented data: each parses to exactly the behaviour the preset
/// builds for its strategy.
#[test]
fn each_file_parses_to_the_built_behaviour() {
    for (symbols, text) in LEAP_BEHAVIOURS {
        let strategy: Strategy = symbols.parse().unwrap();
        let parsed = Behaviour::from_toml_str(text).unwrap();
        let built = leap_behaviour(strategy);
        assert_eq!(parsed, built, "{symbols}");
        // bit for bit (−0.0 and 0.0 compare equal)
        assert_eq!(format!("{parsed:?}"), format!("{built:?}"), "{symbols}");
    }
}
