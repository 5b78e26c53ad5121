//! The four shipped leap behaviour files (`data/behaviours/leap_{pp,pm,mp,mm}.toml`), the
//! data `rhex_model::leap::simulate_leap` runs through the behaviour interpreter of
//! `selfmanip-sim`. That those leaps are the ones the former hand-written leap controller
//! gave, bit for bit, is the engine corpus's check (`scripts/engine-corpus.sh` against a
//! corpus made with that controller); here, that each file is its strategy.
use rhex_model::leap::leap_behaviour;
use rhex_model::leap::Strategy;

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
