//! Arithmetic expressions in data files: a number field of a behaviour may hold a number or
//! a formula of named parameters, e.g. `"max(0, -t2)"` or `"20 * leg.stall_torque_n_m"`.
//!
//! Grammar (f64 arithmetic, IEEE semantics, evaluated left to right):
//!
//! ```text
//! expr    := compare
//! compare := sum (('<' | '<=' | '>' | '>=' | '==' | '!=') sum)?     (1 if true, 0 if false)
//! sum     := product (('+' | '-') product)*
//! product := unary (('*' | '/') unary)*
//! unary   := '-' unary | atom
//! atom    := number | name | name '(' expr (',' expr)* ')' | '(' expr ')'
//! ```
//!
//! Names are letters, digits, `_` and `.` (`leg.stall_torque_n_m`). Functions: `min(a, b)`,
//! `max(a, b)`, `abs(a)`, `sqrt(a)`, `sin(a)`, `cos(a)`, `if(c, a, b)` (`a` where `c ≠ 0`,
//! else `b`). A hand-written parser of ~200 lines rather than a dependency: the expression
//! crates we looked at mix integer and float arithmetic (`7 / 2 = 3`), which a physical
//! parameter must never see, and bound neither nesting nor size.
//!
//! A formula holds at most [`MAX_EXPR_BYTES`] bytes and nests at most [`MAX_EXPR_DEPTH`]
//! deep (parentheses, calls, signs, and chains of `+ - * /`, which nest to the left): the
//! parser, [`Expr::eval`], [`Expr::eval_grad`] and dropping a tree recurse through its
//! depth, so a bounded depth is what keeps them inside any thread's stack. Parameters that
//! refer to each other form chains of at most [`MAX_PARAMETER_CHAIN`] links.
use crate::error::SimError;

/// The longest formula, in bytes.
pub const MAX_EXPR_BYTES: usize = 10_000;
/// The deepest formula: each parenthesis, call and sign is a level, and so is each operator
/// of a chain (`1 + 2 + 3` is `(1 + 2) + 3`, 2 levels).
pub const MAX_EXPR_DEPTH: usize = 100;
/// The longest chain of parameters whose formulas use each other (`a = b + 1`, `b = c`, …).
pub const MAX_PARAMETER_CHAIN: usize = 256;

/// A parsed expression.
#[derive(Debug, Clone, PartialEq)]
pub enum Expr {
    Num(f64),
    Var(String),
    Neg(Box<Expr>),
    Bin(Op, Box<Expr>, Box<Expr>),
    Call(Func, Vec<Expr>),
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    Add,
    Sub,
    Mul,
    Div,
    Lt,
    Le,
    Gt,
    Ge,
    Eq,
    Ne,
}

impl Op {
    /// `x op y`; a comparison is 1 where it holds, else 0.
    pub fn apply(self, x: f64, y: f64) -> f64 {
        let truth = |c: bool| if c { 1.0 } else { 0.0 };
        match self {
            Op::Add => x + y,
            Op::Sub => x - y,
            Op::Mul => x * y,
            Op::Div => x / y,
            Op::Lt => truth(x < y),
            Op::Le => truth(x <= y),
            Op::Gt => truth(x > y),
            Op::Ge => truth(x >= y),
            Op::Eq => truth(x == y),
            Op::Ne => truth(x != y),
        }
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Func {
    Min,
    Max,
    Abs,
    Sqrt,
    Sin,
    Cos,
    If,
}

impl Func {
    fn parse(name: &str) -> Option<(Func, usize)> {
        Some(match name {
            "min" => (Func::Min, 2),
            "max" => (Func::Max, 2),
            "abs" => (Func::Abs, 1),
            "sqrt" => (Func::Sqrt, 1),
            "sin" => (Func::Sin, 1),
            "cos" => (Func::Cos, 1),
            "if" => (Func::If, 3),
            _ => return None,
        })
    }
}

impl Expr {
    /// Parses `text`; errors name `field`.
    pub fn parse(field: &str, text: &str) -> Result<Expr, SimError> {
        let err = |reason: String| SimError::Expression {
            field: field.to_string(),
            expr: shortened(text),
            reason,
        };
        if text.len() > MAX_EXPR_BYTES {
            return Err(err(format!(
                "{} bytes is longer than the {MAX_EXPR_BYTES} a formula may hold",
                text.len()
            )));
        }
        let mut p = Parser {
            s: text.as_bytes(),
            i: 0,
            nesting: 0,
        };
        let (e, _) = p.compare().map_err(err)?;
        p.ws();
        if p.i != p.s.len() {
            return Err(err(format!("unexpected `{}`", &text[p.i..])));
        }
        Ok(e)
    }

    /// The names the expression reads, in order of appearance.
    pub fn variables(&self, out: &mut Vec<String>) {
        match self {
            Expr::Num(_) => {}
            Expr::Var(v) => {
                if !out.contains(v) {
                    out.push(v.clone())
                }
            }
            Expr::Neg(a) => a.variables(out),
            Expr::Bin(_, a, b) => {
                a.variables(out);
                b.variables(out);
            }
            Expr::Call(_, args) => args.iter().for_each(|a| a.variables(out)),
        }
    }

    /// Evaluates with `lookup` for the variables (`None`: unknown name).
    pub fn eval(&self, lookup: &dyn Fn(&str) -> Option<f64>) -> Result<f64, String> {
        Ok(match self {
            Expr::Num(x) => *x,
            Expr::Var(v) => lookup(v).ok_or_else(|| format!("unknown name `{v}`"))?,
            Expr::Neg(a) => -a.eval(lookup)?,
            Expr::Bin(op, a, b) => op.apply(a.eval(lookup)?, b.eval(lookup)?),
            Expr::Call(f, args) => {
                let v = |i: usize| args[i].eval(lookup);
                match f {
                    Func::Min => v(0)?.min(v(1)?),
                    Func::Max => v(0)?.max(v(1)?),
                    Func::Abs => v(0)?.abs(),
                    Func::Sqrt => v(0)?.sqrt(),
                    Func::Sin => v(0)?.sin(),
                    Func::Cos => v(0)?.cos(),
                    Func::If => {
                        if v(0)? != 0.0 {
                            v(1)?
                        } else {
                            v(2)?
                        }
                    }
                }
            }
        })
    }
}

/// A value with its gradient over some inputs (forward mode, [`Expr::eval_grad`]).
pub type Dual = (f64, Vec<f64>);

impl Expr {
    /// [`Self::eval`] with the gradient over `n` inputs, forward mode through the tree:
    /// `lookup` gives each name's value and gradient (`n` entries). The value is `eval`'s,
    /// operation for operation. A comparison has no derivative (it is piecewise constant);
    /// `min`, `max`, `abs` and `if` take the derivative of the branch their value comes from
    /// (at a tie, `min`/`max` the first argument's, `abs` at 0 the argument's: one-sided).
    pub fn eval_grad(
        &self,
        n: usize,
        lookup: &dyn Fn(&str) -> Option<Dual>,
    ) -> Result<Dual, String> {
        let scale = |a: f64, g: &[f64]| g.iter().map(|x| a * x).collect::<Vec<f64>>();
        let lin = |a: f64, g: &[f64], b: f64, h: &[f64]| {
            g.iter()
                .zip(h)
                .map(|(x, y)| a * x + b * y)
                .collect::<Vec<f64>>()
        };
        Ok(match self {
            Expr::Num(x) => (*x, vec![0.0; n]),
            Expr::Var(v) => lookup(v).ok_or_else(|| format!("unknown name `{v}`"))?,
            Expr::Neg(a) => {
                let (x, g) = a.eval_grad(n, lookup)?;
                (-x, scale(-1.0, &g))
            }
            Expr::Bin(op, a, b) => {
                let ((x, g), (y, h)) = (a.eval_grad(n, lookup)?, b.eval_grad(n, lookup)?);
                let gradient = match op {
                    Op::Add => lin(1.0, &g, 1.0, &h),
                    Op::Sub => lin(1.0, &g, -1.0, &h),
                    Op::Mul => lin(y, &g, x, &h),
                    Op::Div => lin(1.0 / y, &g, -x / (y * y), &h),
                    // piecewise constant
                    Op::Lt | Op::Le | Op::Gt | Op::Ge | Op::Eq | Op::Ne => vec![0.0; n],
                };
                (op.apply(x, y), gradient)
            }
            Expr::Call(f, args) => {
                let v = |i: usize| args[i].eval_grad(n, lookup);
                match f {
                    Func::Min | Func::Max => {
                        let ((x, g), (y, h)) = (v(0)?, v(1)?);
                        let value = if *f == Func::Min { x.min(y) } else { x.max(y) };
                        // the argument the value is (the first at a tie)
                        (value, if value == x || y.is_nan() { g } else { h })
                    }
                    Func::Abs => {
                        let (x, g) = v(0)?;
                        (x.abs(), if x < 0.0 { scale(-1.0, &g) } else { g })
                    }
                    Func::Sqrt => {
                        let (x, g) = v(0)?;
                        let r = x.sqrt();
                        (r, scale(0.5 / r, &g))
                    }
                    Func::Sin => {
                        let (x, g) = v(0)?;
                        (x.sin(), scale(x.cos(), &g))
                    }
                    Func::Cos => {
                        let (x, g) = v(0)?;
                        (x.cos(), scale(-x.sin(), &g))
                    }
                    Func::If => {
                        if v(0)?.0 != 0.0 {
                            v(1)?
                        } else {
                            v(2)?
                        }
                    }
                }
            }
        })
    }
}

/// `text` for an error message: long formulas cut to their first 60 characters.
fn shortened(text: &str) -> String {
    match text.char_indices().nth(60) {
        Some((end, _)) => format!("{}… ({} bytes)", &text[..end], text.len()),
        None => text.to_string(),
    }
}

/// A parsed subtree and its depth (a leaf is 0 deep).
type Node = (Expr, usize);

/// `depth` if a tree may be that deep ([`MAX_EXPR_DEPTH`]).
fn within_depth(depth: usize) -> Result<usize, String> {
    if depth > MAX_EXPR_DEPTH {
        Err(format!(
            "nests deeper than the {MAX_EXPR_DEPTH} levels a formula may have"
        ))
    } else {
        Ok(depth)
    }
}

fn bin(op: Op, (a, da): Node, (b, db): Node) -> Result<Node, String> {
    let depth = within_depth(da.max(db) + 1)?;
    Ok((Expr::Bin(op, Box::new(a), Box::new(b)), depth))
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
    /// How many parentheses, calls and signs enclose the position: bounded before each
    /// recursion, so that the parser's own stack stays within [`MAX_EXPR_DEPTH`] levels.
    nesting: usize,
}

impl Parser<'_> {
    /// Runs `inner` one nesting level down.
    fn nested(
        &mut self,
        inner: impl FnOnce(&mut Self) -> Result<Node, String>,
    ) -> Result<Node, String> {
        self.nesting = within_depth(self.nesting + 1)?;
        let out = inner(self);
        self.nesting -= 1;
        out
    }

    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn peek(&mut self) -> Option<u8> {
        self.ws();
        self.s.get(self.i).copied()
    }

    fn eat(&mut self, tok: &str) -> bool {
        self.ws();
        if self.s[self.i..].starts_with(tok.as_bytes()) {
            self.i += tok.len();
            true
        } else {
            false
        }
    }

    fn compare(&mut self) -> Result<Node, String> {
        let a = self.sum()?;
        // two-character operators first
        for (tok, op) in [
            ("<=", Op::Le),
            (">=", Op::Ge),
            ("==", Op::Eq),
            ("!=", Op::Ne),
            ("<", Op::Lt),
            (">", Op::Gt),
        ] {
            if self.eat(tok) {
                let b = self.sum()?;
                return bin(op, a, b);
            }
        }
        Ok(a)
    }

    fn sum(&mut self) -> Result<Node, String> {
        self.left_associative([(b'+', Op::Add), (b'-', Op::Sub)], Self::product)
    }

    fn product(&mut self) -> Result<Node, String> {
        self.left_associative([(b'*', Op::Mul), (b'/', Op::Div)], Self::unary)
    }

    /// `operand (op operand)*` folded to the left, `ops` the level's operators by their byte.
    fn left_associative(
        &mut self,
        ops: [(u8, Op); 2],
        operand: fn(&mut Self) -> Result<Node, String>,
    ) -> Result<Node, String> {
        let mut a = operand(self)?;
        loop {
            let next = self.peek();
            let Some(&(_, op)) = ops.iter().find(|(byte, _)| next == Some(*byte)) else {
                return Ok(a);
            };
            self.i += 1;
            let b = operand(self)?;
            a = bin(op, a, b)?;
        }
    }

    fn unary(&mut self) -> Result<Node, String> {
        if self.peek() == Some(b'-') {
            self.i += 1;
            let (a, depth) = self.nested(Self::unary)?;
            return Ok((Expr::Neg(Box::new(a)), within_depth(depth + 1)?));
        }
        self.atom()
    }

    fn atom(&mut self) -> Result<Node, String> {
        match self.peek() {
            None => Err("unexpected end".into()),
            Some(b'(') => {
                self.i += 1;
                let e = self.nested(Self::compare)?;
                if !self.eat(")") {
                    return Err("missing `)`".into());
                }
                Ok(e)
            }
            Some(c) if c.is_ascii_digit() || c == b'.' => {
                let start = self.i;
                while self.i < self.s.len() {
                    let c = self.s[self.i];
                    let exp_sign =
                        (c == b'+' || c == b'-') && matches!(self.s[self.i - 1], b'e' | b'E');
                    if c.is_ascii_digit() || c == b'.' || c == b'e' || c == b'E' || exp_sign {
                        self.i += 1;
                    } else {
                        break;
                    }
                }
                let text = std::str::from_utf8(&self.s[start..self.i]).expect("ascii");
                text.parse::<f64>()
                    .map(|x| (Expr::Num(x), 0))
                    .map_err(|_| format!("bad number `{text}`"))
            }
            Some(c) if c.is_ascii_alphabetic() || c == b'_' => {
                let start = self.i;
                while self.i < self.s.len()
                    && (self.s[self.i].is_ascii_alphanumeric()
                        || self.s[self.i] == b'_'
                        || self.s[self.i] == b'.')
                {
                    self.i += 1;
                }
                let name = std::str::from_utf8(&self.s[start..self.i]).expect("ascii");
                if self.peek() != Some(b'(') {
                    return Ok((Expr::Var(name.to_string()), 0));
                }
                let (f, arity) =
                    Func::parse(name).ok_or_else(|| format!("unknown function `{name}`"))?;
                self.i += 1;
                let mut args = Vec::new();
                let mut depth = 0;
                loop {
                    let (a, d) = self.nested(Self::compare)?;
                    args.push(a);
                    depth = depth.max(d + 1);
                    if !self.eat(",") {
                        break;
                    }
                }
                if !self.eat(")") {
                    return Err(format!("missing `)` after the arguments of `{name}`"));
                }
                if args.len() != arity {
                    return Err(format!(
                        "`{name}` takes {arity} argument(s), got {}",
                        args.len()
                    ));
                }
                Ok((Expr::Call(f, args), within_depth(depth)?))
            }
            Some(c) => Err(format!("unexpected `{}`", c as char)),
        }
    }
}

/// The parsed formulas of one behaviour by their text, each parsed once: owned by the
/// caller that compiles the behaviour again and again (a [`crate::Simulation`] and its
/// rebinds share one), never global. A formula that fails to parse is not kept (its error
/// is reported where it is read).
#[derive(Debug, Default)]
pub struct ParsedFormulas(
    std::sync::Mutex<std::collections::HashMap<String, std::sync::Arc<Expr>>>,
);

impl ParsedFormulas {
    /// `s` parsed: a number as itself, a formula at its first ask by `parse` (whose error is
    /// returned), then kept.
    pub fn parse(
        &self,
        s: &Scalar,
        parse: impl FnOnce() -> Result<Expr, SimError>,
    ) -> Result<std::sync::Arc<Expr>, SimError> {
        let text = match s {
            Scalar::Number(x) => return Ok(std::sync::Arc::new(Expr::Num(*x))),
            Scalar::Expr(text) => text,
        };
        if let Some(e) = self.0.lock().ok().and_then(|m| m.get(text).cloned()) {
            return Ok(e);
        }
        let e = std::sync::Arc::new(parse()?);
        if let Ok(mut m) = self.0.lock() {
            m.insert(text.clone(), std::sync::Arc::clone(&e));
        }
        Ok(e)
    }
}

/// A number field: a number, or an expression of named parameters.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(untagged)]
pub enum Scalar {
    Number(f64),
    Expr(String),
}

impl From<f64> for Scalar {
    fn from(x: f64) -> Self {
        Scalar::Number(x)
    }
}

impl From<&str> for Scalar {
    fn from(s: &str) -> Self {
        Scalar::Expr(s.to_string())
    }
}

impl Scalar {
    /// The parsed expression (a number is a constant).
    pub fn parse(&self, field: &str) -> Result<Expr, SimError> {
        match self {
            Scalar::Number(x) => Ok(Expr::Num(*x)),
            Scalar::Expr(s) => Expr::parse(field, s),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ev(s: &str, vars: &[(&str, f64)]) -> f64 {
        let e = Expr::parse("x", s).unwrap();
        e.eval(&|n| vars.iter().find(|v| v.0 == n).map(|v| v.1))
            .unwrap()
    }

    #[test]
    fn precedence_and_functions_follow_the_grammar() {
        // each against the same arithmetic written in Rust
        let t2 = -0.07;
        assert_eq!(ev("max(0, -t2)", &[("t2", t2)]), 0f64.max(-t2));
        assert_eq!(ev("1 - 2 * 3 + 4 / 8", &[]), 1.0 - 2.0 * 3.0 + 4.0 / 8.0);
        assert_eq!(ev("-2 * -3", &[]), 6.0);
        assert_eq!(ev("(1 + 2) * 3", &[]), 9.0);
        assert_eq!(ev("2.5e-3 * a.b", &[("a.b", 4.0)]), 2.5e-3 * 4.0);
        assert_eq!(
            ev("if(s * x >= 0, s, -s) * 2.6", &[("s", -1.0), ("x", 0.0)]),
            -2.6
        );
        assert_eq!(
            ev("if(s * x >= 0, s, -s) * 2.6", &[("s", -1.0), ("x", 0.3)]),
            2.6
        );
        assert_eq!(ev("abs(t2) < 0.1", &[("t2", t2)]), 1.0);
    }

    /// The gradient against central differences of the value, for every operation and
    /// function away from their kinks (an independent route: `eval` at perturbed inputs).
    #[test]
    fn gradients_match_central_differences() {
        let cases = [
            "max(0, -t2) * 3 + a / b - sqrt(a * b)",
            "if(s * x >= 0, s, -s) * 2.6 + sin(a) * cos(b)",
            "min(a, b) - abs(x - 1) + -a * (b - x) / (1 + x * x)",
        ];
        let names = ["t2", "a", "b", "s", "x"];
        let at = [-0.07, 1.3, 2.1, -1.0, 0.4];
        for c in cases {
            let e = Expr::parse("x", c).unwrap();
            let value = |v: &[f64]| {
                e.eval(&|n| names.iter().position(|m| *m == n).map(|i| v[i]))
                    .unwrap()
            };
            let (x, g) = e
                .eval_grad(names.len(), &|n| {
                    let i = names.iter().position(|m| *m == n)?;
                    let mut d = vec![0.0; names.len()];
                    d[i] = 1.0;
                    Some((at[i], d))
                })
                .unwrap();
            assert_eq!(x, value(&at), "{c}");
            for i in 0..names.len() {
                let h = 1e-6;
                let (mut p, mut m) = (at, at);
                p[i] += h;
                m[i] -= h;
                let fd = (value(&p) - value(&m)) / (2.0 * h);
                assert!(
                    (g[i] - fd).abs() < 1e-8 * (1.0 + fd.abs()),
                    "{c} d/d{}: {} vs {fd}",
                    names[i],
                    g[i]
                );
            }
        }
    }

    #[test]
    fn bad_expressions_name_their_field() {
        for bad in ["1 +", "max(1)", "foo(2)", "(1", "2 $ 3", "1..2"] {
            match Expr::parse("phases[1].start.at_s", bad) {
                Err(SimError::Expression { field, .. }) => {
                    assert_eq!(field, "phases[1].start.at_s")
                }
                other => panic!("{bad}: {other:?}"),
            }
        }
    }
}
