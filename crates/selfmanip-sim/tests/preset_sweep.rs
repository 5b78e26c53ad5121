//! The preset hook of the generic sweep (`sweep::Preset`, `preset_sweep`) on robots that are
//! not RHex: the scenario preset's rows against the generic sweep's outcomes of the same
//! points (a second route to the same runs), a preset of the user's own (the hopper dropped
//! from a height, reported on a clock and from an origin of its own) against its runs made
//! by hand, failures, panics and a raised stop flag as rows of their own, and the one column
//! vocabulary (`apex_z_m` up) against the engine's NED state at the apex event.
mod common;

use common::data;
use selfmanip_hybrid::budget::NEVER;
use selfmanip_hybrid::EventKind;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::outcome::{BodyState, PresetFrame, APEX_COLUMNS};
use selfmanip_sim::sweep::{
    grid, preset_sweep, run_row, sweep, Preset, ScenarioPreset, SweepPoint, SweepRow,
};
use selfmanip_sim::{Scenario, SimError, Simulation};
use serde_json::json;
use std::sync::atomic::AtomicBool;

/// The hopper of the examples, its foot circle (radius 0.02 m) `drop_m` above the ground,
/// hopping.
fn hopper(drop_m: f64, t_final_s: f64) -> Scenario {
    let mut s = common::examples::dropped_hopper(drop_m + 0.02).unwrap();
    s.behaviour = Behaviour::from_file(&data("hop.toml")).unwrap();
    s.options.t_final_s = t_final_s;
    s
}

fn bits(r: &SweepRow) -> Vec<u64> {
    r.columns
        .iter()
        .chain(&r.apex_columns())
        .map(|v| v.to_bits())
        .collect()
}

/// The scenario preset reports every point as the generic sweep runs it: the same status,
/// word and events, and the outcome's apex (its first apex event, NED) seen upward; rows are
/// bit-identical on any thread count.
#[test]
fn the_scenario_preset_rows_are_the_generic_sweeps_runs() {
    let base = hopper(0.1, 0.5);
    let points = grid(&[
        ("kp_push".into(), vec![json!(35.0), json!(55.0)]),
        ("t_compress".into(), vec![json!(0.04), json!(0.06)]),
    ])
    .unwrap();
    let preset = ScenarioPreset::new(&base).unwrap();
    let rows = preset_sweep(&preset, &points, 1, &NEVER).unwrap();
    let two = preset_sweep(&preset, &points, 2, &NEVER).unwrap();
    assert_eq!(rows, two);
    assert!(preset.columns().is_empty());
    let generic = sweep(&base, &points, 2).unwrap();
    for (row, g) in rows.iter().zip(&generic) {
        let o = g.outcome().unwrap();
        assert_eq!(row.status, o.status.as_str());
        assert_eq!(
            (row.word.as_str(), row.n_events),
            (o.word_string().as_str(), o.n_events)
        );
        let apex = o.apex.expect("the hopper flies");
        assert_eq!(row.apex, Some(apex.upward()));
        // hopping on to its final time after a flight
        assert_eq!(row.status, "final_time");
        assert!(row.flew);
        for r in [&row.apex_columns()[..], &row.columns[..]] {
            assert!(r.iter().all(|v| v.is_finite()));
        }
    }
}

/// One vocabulary: `apex_z_m` is the body centre's height above the ground (z up) and
/// `apex_zdot_m_s` its rate, from the engine's own NED state at the apex event; at an apex
/// the vertical rate vanishes, and the hopper's body is above its ground.
#[test]
fn apex_columns_are_height_up_in_every_sweep() {
    assert_eq!(APEX_COLUMNS[2], "apex_z_m");
    let base = hopper(0.1, 0.5);
    let run = Simulation::new(&base).unwrap().run().unwrap();
    let e = run
        .execution
        .events
        .iter()
        .find(|e| e.kind == EventKind::Apex)
        .expect("an apex event");
    let iz = run.model.ix_z();
    let preset = ScenarioPreset::new(&base).unwrap();
    let row = run_row(&preset, &SweepPoint::default(), &NEVER);
    let a = row.apex.unwrap();
    assert_eq!(a.z_m, -e.q[iz]);
    assert!(a.z_m > 0.0, "the body is above the ground: {}", a.z_m);
    assert!(a.zdot_m_s.abs() < 1e-6, "{}", a.zdot_m_s);
    assert_eq!(row.apex_columns()[2], a.z_m);
}

/// A preset of the user's own: a point is the drop height, the clock starts 0.1 s into the
/// run, x from 1 m; one column, the drop height. Its rows are its runs made by hand in that
/// frame; a bad point is a row of its error kind, a panic a `panic` row, a raised stop flag
/// `interrupted` rows — all with NaN columns — and the good points stay as they are.
struct Drop;

impl Preset for Drop {
    type Point = f64;
    type Error = SimError;

    fn columns(&self) -> &'static [&'static str] {
        &["drop_m"]
    }

    fn run(&self, drop_m: &f64, stop: &AtomicBool) -> Result<SweepRow, SimError> {
        assert!(*drop_m < 1.0, "a drop from a metre or more");
        let run = Simulation::new(&hopper(*drop_m, 0.5))?.run_with(stop)?;
        let frame = PresetFrame {
            t0_s: 0.1,
            drive_start_s: 0.0,
            x0_m: 1.0,
            stop_at_apex: false,
        };
        let flew = frame.flew(&run.execution, run.outcome.status);
        let apex = frame.apex(&run.model, &run.execution);
        Ok(SweepRow::of_run(
            &run.outcome,
            flew,
            apex,
            String::new(),
            vec![*drop_m],
        ))
    }

    fn error_kind(&self, e: &SimError) -> &'static str {
        e.kind()
    }
}

#[test]
fn a_user_preset_runs_through_the_generic_sweep() {
    let points = [0.05, -0.5, 0.1, 2.0];
    let rows = preset_sweep(&Drop, &points, 2, &NEVER).unwrap();
    // the same rows on one thread (NaN columns compared by their text)
    let one = preset_sweep(&Drop, &points, 1, &NEVER).unwrap();
    assert_eq!(format!("{rows:?}"), format!("{one:?}"));
    for (i, drop_m) in [(0, 0.05), (2, 0.1)] {
        let run = Simulation::new(&hopper(drop_m, 0.5))
            .unwrap()
            .run()
            .unwrap();
        let o = &run.outcome;
        let a = o.apex.unwrap();
        // by hand: the frame's clock and origin, z up
        let by_hand = BodyState {
            t_s: a.t_s - 0.1,
            x_m: a.x_m - 1.0,
            ..a.upward()
        };
        assert_eq!(rows[i].apex, Some(by_hand));
        assert_eq!(rows[i].columns, vec![drop_m]);
        assert_eq!(rows[i].status, o.status.as_str());
    }
    // a foot below the ground: the engine's typed error, as its kind
    assert_eq!(rows[1].status, "invalid_value");
    assert!(rows[1].error.contains("initial.q"), "{}", rows[1].error);
    assert_eq!(rows[3].status, "panic");
    assert!(rows[3].error.contains("a metre or more"));
    for r in [&rows[1], &rows[3]] {
        assert!(r.columns[0].is_nan() && r.apex.is_none() && !r.flew);
    }
    let raised = AtomicBool::new(true);
    let rows = preset_sweep(&Drop, &points, 2, &raised).unwrap();
    assert!(rows
        .iter()
        .all(|r| r.status == "interrupted" && r.columns[0].is_nan()));
    assert!(preset_sweep(&Drop, &points, 0, &NEVER).is_err());
    assert_eq!(bits(&rows[0]).len(), 1 + APEX_COLUMNS.len());
}
