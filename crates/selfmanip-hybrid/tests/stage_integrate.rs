//! Stage `integrate`: Dormand–Prince 5(4) steps and their dense output, kept in one buffer,
//! against the closed-form harmonic oscillator `x = cos t`, `ẋ = −sin t`.
use selfmanip_hybrid::integrate::{DenseOutput, DenseStep, Dopri5};
use selfmanip_hybrid::StepOptions;

#[test]
fn dense_output_evaluates_as_its_steps_and_as_the_closed_form() {
    let mut f = |_t: f64, y: &[f64], d: &mut [f64]| -> Result<(), ()> {
        d[0] = y[1];
        d[1] = -y[0];
        Ok(())
    };
    let mut ode = Dopri5::new(
        2,
        StepOptions {
            rtol: 1e-10,
            atol: 1e-12,
            ..Default::default()
        },
    );
    let (mut t, mut y) = (0.0, vec![1.0, 0.0]);
    let mut step = DenseStep::default();
    let mut out = DenseOutput::default();
    let mut steps = Vec::new();
    while t < 6.0 {
        ode.step(&mut f, t, &mut y, 6.0, &mut step).unwrap();
        out.push(&step);
        steps.push(step.clone());
        t = step.t1();
    }
    assert_eq!(out.len(), steps.len());
    let (mut a, mut b) = ([0.0; 2], [0.0; 2]);
    for (i, s) in steps.iter().enumerate() {
        for frac in [0.0, 0.3, 0.9] {
            let tt = s.t0 + frac * s.h;
            s.eval(tt, &mut a);
            // the step that holds tt (a step's start is the previous one's end)
            let view = out.step(i);
            view.eval(tt, &mut b);
            assert_eq!(a, b, "the buffer holds each step's coefficients unchanged");
            out.eval(tt, &mut b);
            assert!((b[0] - tt.cos()).abs() < 1e-8 && (b[1] + tt.sin()).abs() < 1e-8);
        }
    }
    // the steps' end points: 5th-order accurate
    assert!((y[0] - t.cos()).abs() < 1e-8 && (y[1] + t.sin()).abs() < 1e-8);
    // the start: the first step's interpolant at its own start is the initial state
    out.eval(0.0, &mut b);
    assert_eq!(b, [1.0, 0.0]);
}
