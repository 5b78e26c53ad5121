//! Formulas and parameter chains are bounded before anything recurses through them (issue
//! 31: 10,000 nested parentheses, a sum of 100,000 terms or a chain of 20,000 parameters
//! overflowed the stack of the process or of a sweep's worker thread). Each case is refused
//! with [`SimError::Expression`] or [`SimError::InvalidValue`] naming the parameter, and
//! the formulas at the bounds still evaluate to their closed form.
use selfmanip_core::RobotDescription;
use selfmanip_sim::behaviour::Behaviour;
use selfmanip_sim::expr::{Expr, MAX_EXPR_BYTES, MAX_EXPR_DEPTH, MAX_PARAMETER_CHAIN};
use selfmanip_sim::{Scenario, SimError, Simulation};
use serde_json::{json, Map, Value};
use std::path::Path;

fn hopper_with(parameters: Map<String, Value>) -> Result<Simulation, SimError> {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data");
    let robot = RobotDescription::from_file(&data.join("hopper.toml")).unwrap();
    let mut s = Scenario::new(robot, vec![0.5, -1.0, 0.0, -0.451, 0.0]);
    let behaviour = json!({
        "parameters": parameters,
        "joints": [{"joint": "leg[1]", "phases": [{"name": "a",
            "torque": {"kind": "constant", "torque_n_m": "p"}}]}],
    });
    s.behaviour = Behaviour::from_json_str(&behaviour.to_string()).unwrap();
    s.options.t_final_s = 0.01;
    Simulation::new(&s)
}

fn one(name: &str, formula: String) -> Map<String, Value> {
    let mut m = Map::new();
    m.insert(name.into(), Value::String(formula));
    m
}

fn expression_field(r: Result<Simulation, SimError>) -> (String, String) {
    match r.err().expect("refused") {
        SimError::Expression {
            field,
            reason,
            expr,
        } => {
            assert!(
                expr.len() < 200,
                "the message quotes a bounded excerpt: {expr}"
            );
            (field, reason)
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn ten_thousand_nested_parentheses_are_refused_naming_the_parameter() {
    let deep = format!("{}1{}", "(".repeat(10_000), ")".repeat(10_000));
    let (field, reason) = expression_field(hopper_with(one("p", deep)));
    assert_eq!(field, "parameters.p");
    assert!(reason.contains("bytes"), "{reason}");
    // within the byte bound, past the depth bound
    let deep = format!("{}1{}", "(".repeat(1_000), ")".repeat(1_000));
    let (field, reason) = expression_field(hopper_with(one("p", deep)));
    assert_eq!(field, "parameters.p");
    assert!(reason.contains("nests deeper"), "{reason}");
    let signs = format!("{}1", "-".repeat(5_000));
    let (_, reason) = expression_field(hopper_with(one("p", signs)));
    assert!(reason.contains("nests deeper"), "{reason}");
}

#[test]
fn a_sum_of_a_hundred_thousand_terms_is_refused_naming_the_parameter() {
    let long = vec!["1"; 100_000].join("+");
    let (field, _) = expression_field(hopper_with(one("p", long)));
    assert_eq!(field, "parameters.p");
    // a chain of `+` nests to the left: one term more than the depth bound allows
    let sum = vec!["1"; MAX_EXPR_DEPTH + 2].join(" + ");
    assert!(sum.len() < MAX_EXPR_BYTES);
    let (field, reason) = expression_field(hopper_with(one("p", sum)));
    assert_eq!(field, "parameters.p");
    assert!(reason.contains("nests deeper"), "{reason}");
}

/// The deepest formulas allowed evaluate to their closed form, with their gradient, on a
/// thread with a 256 KiB stack (a tenth of a sweep worker's): the bound is what keeps every
/// recursion through them small.
#[test]
fn formulas_at_the_bounds_evaluate_on_a_small_stack() {
    std::thread::Builder::new()
        .stack_size(256 * 1024)
        .spawn(|| {
            // n terms of x: n x, gradient n
            let n = MAX_EXPR_DEPTH + 1;
            let sum = Expr::parse("s", &vec!["x"; n].join(" + ")).unwrap();
            let (v, g) = sum.eval_grad(1, &|_| Some((0.5, vec![1.0]))).unwrap();
            assert_eq!((v, g[0]), (0.5 * n as f64, n as f64));
            // MAX_EXPR_DEPTH nested parentheses around one value
            let half = MAX_EXPR_DEPTH / 2;
            let nested = format!("{}-x{}", "(".repeat(half), ")".repeat(half));
            let e = Expr::parse("n", &nested).unwrap();
            assert_eq!(e.eval(&|_| Some(2.0)).unwrap(), -2.0);
            // (((x*x)*x)...) and sqrt/min nesting: x^k and its derivative k x^(k-1)
            let k = 40;
            let pow = vec!["x"; k].join(" * ");
            let e = Expr::parse("m", &format!("max(sqrt(({pow}) * ({pow})), 0)")).unwrap();
            let (v, g) = e.eval_grad(1, &|_| Some((1.01, vec![1.0]))).unwrap();
            let closed = 1.01f64.powi(k as i32);
            assert!((v - closed).abs() < 1e-12 * closed, "{v} {closed}");
            let dclosed = k as f64 * 1.01f64.powi(k as i32 - 1);
            assert!(
                (g[0] - dclosed).abs() < 1e-10 * dclosed,
                "{} {dclosed}",
                g[0]
            );
        })
        .unwrap()
        .join()
        .unwrap();
}

/// `c_i = c_{i+1} + 1` down to `c_{n−1} = 1` (named so that the head is resolved first, the
/// whole chain deep): 20,000 links are refused naming a parameter of the chain, and the
/// bound is exact.
#[test]
fn a_chain_of_twenty_thousand_parameters_is_refused_naming_a_parameter() {
    let chain = |n: usize| {
        let mut m = Map::new();
        for i in 0..n - 1 {
            m.insert(
                format!("c{i:05}"),
                Value::String(format!("c{:05} + 1", i + 1)),
            );
        }
        m.insert(format!("c{:05}", n - 1), json!(1.0));
        m.insert("p".into(), Value::String("c00000".into()));
        m
    };
    for n in [20_000, MAX_PARAMETER_CHAIN + 1] {
        match hopper_with(chain(n)).err().expect("refused") {
            SimError::InvalidValue { field, reason } => {
                assert!(field.starts_with("parameters.c"), "{field}");
                assert!(
                    reason.contains(&MAX_PARAMETER_CHAIN.to_string()),
                    "{reason}"
                );
            }
            other => panic!("{n}: {other:?}"),
        }
    }
    assert!(hopper_with(chain(MAX_PARAMETER_CHAIN)).is_ok());
}
