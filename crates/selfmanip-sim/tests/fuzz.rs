//! Property tests of the parsers a user's text reaches (issue 31): formulas, robot
//! descriptions and terrains. Random and adversarial input gives a value or a typed error,
//! never a panic, a stack overflow or a non-finite value taken for a good one; a formula
//! that parses evaluates as the tree it was printed from, by an evaluator written here (a
//! second route). Fixed case counts keep CI's time bounded (`PROPTEST_CASES` overrides).
use proptest::prelude::*;
use selfmanip_core::RobotDescription;
use selfmanip_sim::expr::{Expr, MAX_EXPR_DEPTH};
use selfmanip_sim::{SimError, TerrainSpec};

/// A formula tree as this test writes and evaluates it.
#[derive(Debug, Clone)]
enum Tree {
    Num(f64),
    Var(usize),
    Neg(Box<Tree>),
    Bin(char, Box<Tree>, Box<Tree>),
    Call(&'static str, Vec<Tree>),
}

const VARS: [&str; 3] = ["a", "leg.k", "t_2"];
const VALUES: [f64; 3] = [0.7, -1.3, 2.5];

impl Tree {
    /// Fully parenthesized text, so the grammar's precedence plays no part.
    fn text(&self) -> String {
        match self {
            Tree::Num(x) => format!("{x:e}"),
            Tree::Var(i) => VARS[*i].to_string(),
            Tree::Neg(a) => format!("(-{})", a.text()),
            Tree::Bin(op, a, b) => format!("({} {op} {})", a.text(), b.text()),
            Tree::Call(f, args) => format!(
                "{f}({})",
                args.iter().map(Tree::text).collect::<Vec<_>>().join(", ")
            ),
        }
    }

    fn eval(&self) -> f64 {
        match self {
            Tree::Num(x) => *x,
            Tree::Var(i) => VALUES[*i],
            Tree::Neg(a) => -a.eval(),
            Tree::Bin(op, a, b) => {
                let (x, y) = (a.eval(), b.eval());
                match op {
                    '+' => x + y,
                    '-' => x - y,
                    '*' => x * y,
                    '/' => x / y,
                    _ => f64::from(u8::from(x < y)),
                }
            }
            Tree::Call(f, args) => {
                let v: Vec<f64> = args.iter().map(Tree::eval).collect();
                match *f {
                    "min" => v[0].min(v[1]),
                    "max" => v[0].max(v[1]),
                    "abs" => v[0].abs(),
                    "sqrt" => v[0].sqrt(),
                    "sin" => v[0].sin(),
                    "cos" => v[0].cos(),
                    _ => {
                        if v[0] != 0.0 {
                            v[1]
                        } else {
                            v[2]
                        }
                    }
                }
            }
        }
    }
}

fn tree() -> impl Strategy<Value = Tree> {
    let leaf = prop_oneof![
        (-1e3f64..1e3).prop_map(Tree::Num),
        (0usize..3).prop_map(Tree::Var),
    ];
    leaf.prop_recursive(6, 48, 3, |inner| {
        prop_oneof![
            inner.clone().prop_map(|a| Tree::Neg(Box::new(a))),
            (
                prop::sample::select(vec!['+', '-', '*', '/', '<']),
                inner.clone(),
                inner.clone()
            )
                .prop_map(|(op, a, b)| Tree::Bin(op, Box::new(a), Box::new(b))),
            (
                prop::sample::select(vec!["min", "max"]),
                inner.clone(),
                inner.clone()
            )
                .prop_map(|(f, a, b)| Tree::Call(f, vec![a, b])),
            (
                prop::sample::select(vec!["abs", "sqrt", "sin", "cos"]),
                inner.clone()
            )
                .prop_map(|(f, a)| Tree::Call(f, vec![a])),
            (inner.clone(), inner.clone(), inner)
                .prop_map(|(c, a, b)| Tree::Call("if", vec![c, a, b])),
        ]
    })
}

fn lookup(name: &str) -> Option<f64> {
    VARS.iter().position(|v| *v == name).map(|i| VALUES[i])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    /// A printed tree parses and evaluates to the tree's own value, bit for bit (NaN to NaN).
    #[test]
    fn a_printed_formula_evaluates_as_its_tree(t in tree()) {
        let text = t.text();
        let e = Expr::parse("f", &text).unwrap();
        let (ours, theirs) = (e.eval(&lookup).unwrap(), t.eval());
        prop_assert!(ours.to_bits() == theirs.to_bits() || (ours.is_nan() && theirs.is_nan()),
            "{text}: {ours} vs {theirs}");
    }

    /// Any text over the grammar's characters: a tree or a typed error naming the field,
    /// never a panic (unbalanced parentheses, stray operators, numbers like `1e`, `..`).
    #[test]
    fn any_text_parses_or_names_its_field(text in "[-+*/()<>=!,. 0-9a-z_eE]{0,200}") {
        match Expr::parse("parameters.p", &text) {
            Ok(e) => { let _ = e.eval(&lookup); }
            Err(SimError::Expression { field, .. }) => prop_assert_eq!(field, "parameters.p"),
            Err(other) => prop_assert!(false, "{other:?}"),
        }
    }

    /// Nesting of any depth up to ten times the bound: accepted exactly within it.
    #[test]
    fn nesting_is_accepted_exactly_within_the_bound(depth in 0usize..10 * MAX_EXPR_DEPTH,
                                                    kind in 0usize..3) {
        let text = match kind {
            0 => format!("{}1{}", "(".repeat(depth), ")".repeat(depth)),
            1 => format!("{}1", "-".repeat(depth)),
            _ => vec!["1"; depth + 1].join("+"),
        };
        let parsed = Expr::parse("p", &text);
        prop_assert_eq!(parsed.is_ok(), depth <= MAX_EXPR_DEPTH, "{} {}", kind, depth);
        if let Ok(e) = parsed {
            let v = e.eval(&|_| None).unwrap();
            let expected = match kind { 0 => 1.0, 1 => if depth % 2 == 0 { 1.0 } else { -1.0 },
                                        _ => (depth + 1) as f64 };
            prop_assert_eq!(v, expected);
        }
    }

    /// Terrains from arbitrary JSON objects: a spec that passes `validate` has finite
    /// heights everywhere; the rest is a typed error.
    #[test]
    fn terrains_validate_or_name_a_field(
        kind in prop::sample::select(vec!["flat", "incline", "ledge", "stairs", "cliff"]),
        keys in prop::collection::vec((prop::sample::select(vec![
            "slope_rad", "height_m", "distance_m", "rise_m", "run_m", "count", "extra"]),
            prop_oneof![Just(f64::MAX), Just(-1.0), Just(0.0), -2.0f64..2.0, Just(1e308)]), 0..5),
        xs in prop::collection::vec(-1e3f64..1e3, 4),
    ) {
        let mut obj = serde_json::Map::new();
        obj.insert("kind".into(), kind.into());
        for (k, v) in keys {
            let v = if k == "count" { serde_json::json!(v.abs().min(1e6) as u64) } else { serde_json::json!(v) };
            obj.insert(k.into(), v);
        }
        match serde_json::from_value::<TerrainSpec>(serde_json::Value::Object(obj)) {
            Ok(spec) => {
                if spec.validate().is_ok() {
                    for x in xs {
                        prop_assert!(spec.height_at(x).is_finite(), "{spec:?} at {x}");
                    }
                }
            }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }

    /// Robot descriptions from random fields and nesting: a model or a typed error.
    #[test]
    fn descriptions_load_or_name_a_field(
        mass in prop_oneof![Just(0.0), Just(-1.0), Just(1e308), 0.01f64..10.0],
        length in prop_oneof![Just(0.0), Just(f64::MAX), 0.01f64..1.0],
        links in 0usize..4,
        depth in 0usize..200,
        extra in any::<bool>(),
    ) {
        let link = serde_json::json!({"length_m": length, "mass_kg": mass});
        let mut legs = serde_json::json!([{"name": "leg", "hip_m": [0.0, 0.0],
            "links": vec![link; links]}]);
        for _ in 0..depth % 50 {
            legs = serde_json::json!([legs]);
        }
        let mut d = serde_json::json!({"name": "r", "body": {"mass_kg": mass, "inertia_kg_m2": 0.1},
            "legs": legs});
        if extra {
            d["bogus"] = serde_json::json!(1);
        }
        match RobotDescription::from_json_str(&d.to_string()) {
            Ok(r) => { let _ = r.build(); }
            Err(e) => prop_assert!(!e.to_string().is_empty()),
        }
    }
}
