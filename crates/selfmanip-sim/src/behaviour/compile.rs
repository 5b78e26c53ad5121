//! Checking a behaviour against a robot and compiling it into a [`BehaviourController`]:
//! names resolved to indices, parameters and formulas evaluated, every value checked. Each
//! error names the field at fault (`joints[1].phases[2].torque.kp_n_m_per_rad`).
use super::interpreter::{
    servo_manifold, BehaviourController, EventMatch, Level, MatchKind, MotionLaw, NamedPlan,
    PhasePlan, Plan, Program, ServoLaw, Start, TorqueLaw, Value,
};
use super::spec::{
    ActuatorSpec, Behaviour, Interpolation, JointProgram, Motion, NamedEvent, On, Phase, Torque,
    Trigger,
};
use super::tangent::{
    ActuatorLaw, GearedLaw, GearedLosses, Grad, NumberTangent, PhaseTangent, PlanTangent,
    TorqueTangent,
};
use crate::error::{finite, invalid, non_negative, positive, SimError};
use crate::expr::{Expr, ParsedFormulas, Scalar, MAX_PARAMETER_CHAIN};
use crate::labels::{contact_by_name, joint_contacts, joint_index, joint_name};
use motor::Actuator;
use selfmanip_core::Model;
use selfmanip_hybrid::EventKind;
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};

fn known_joints(model: &Model) -> String {
    (0..model.n_joints())
        .map(|j| joint_name(model, j))
        .collect::<Vec<_>>()
        .join(", ")
}

/// Evaluates parameters and formulas.
struct Context<'a> {
    model: &'a Model,
    /// Parameters and actuator constants by name.
    values: BTreeMap<String, f64>,
    /// Their gradients over the parameters (`tangent.rs`).
    grads: BTreeMap<String, Grad>,
    /// The number of parameters.
    n: usize,
    /// Whether gradients are computed (else every gradient is [`Self::empty`]: the plan's
    /// tangent is built on first use, [`compile`]).
    tangent: bool,
    empty: Grad,
    /// The behaviour's formulas, parsed once for all its compilations.
    formulas: &'a ParsedFormulas,
    /// While a part is compiled for [`ReusableParts`]: the names it reads from
    /// [`Self::values`] with their values' bits.
    log: RefCell<Option<Vec<(String, u64)>>>,
}

/// The path of a field, for the errors that name it: formatted only when one does.
trait FieldPath: std::fmt::Display {
    fn path(&self) -> String {
        self.to_string()
    }
}

impl FieldPath for str {}

impl FieldPath for String {}

/// The field `leaf` of the field `parent`: `parent.leaf`.
struct Leaf<'a, P: FieldPath + ?Sized>(&'a P, &'a str);

impl<P: FieldPath + ?Sized> std::fmt::Display for Leaf<'_, P> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}.{}", self.0, self.1)
    }
}

impl<P: FieldPath + ?Sized> FieldPath for Leaf<'_, P> {}

/// `check` (a check of a value that names its field in its error), with `field`'s path
/// formatted only when it fails.
fn named<T>(
    field: &(impl FieldPath + ?Sized),
    check: impl Fn(&str) -> Result<T, SimError>,
) -> Result<T, SimError> {
    check("").or_else(|_| check(&field.path()))
}

/// `v` (a speed or an acceleration of a motion) at most `f64::MAX / 2`, else an error naming
/// `field`: the free joints' tracking law differences two of them at each segment's start
/// (`selfmanip_hybrid::free_joints`), which a larger value would overflow.
fn differenceable(field: &str, v: f64) -> Result<f64, SimError> {
    if (2.0 * v).is_finite() {
        Ok(v)
    } else {
        Err(invalid(
            field,
            format!(
                "must be at most f64::MAX / 2 (the free joints' tracking law is differenced), \
                 got {v}"
            ),
        ))
    }
}

/// Every name `e` reads, once each, in order of appearance (in every branch), appended to
/// `out` ([`Expr::variables`] without copying them).
fn names<'e>(e: &'e Expr, out: &mut Vec<&'e str>) {
    match e {
        Expr::Num(_) => {}
        Expr::Var(v) => {
            if !out.contains(&v.as_str()) {
                out.push(v);
            }
        }
        Expr::Neg(a) => names(a, out),
        Expr::Bin(_, a, b) => {
            names(a, out);
            names(b, out);
        }
        Expr::Call(_, args) => args.iter().for_each(|a| names(a, out)),
    }
}

/// `e` with the values of the names it reads (`read`, from [`names`]); an error names
/// `field` and quotes `expr`.
fn eval_read(
    e: &Expr,
    read: &[(&str, f64)],
    field: &(impl FieldPath + ?Sized),
    expr: &dyn Fn() -> String,
) -> Result<f64, SimError> {
    e.eval(&|n| read.iter().find(|(k, _)| *k == n).map(|(_, v)| *v))
        .map_err(|reason| SimError::Expression {
            field: field.path(),
            expr: expr(),
            reason,
        })
}

/// Whether `e` reads a name that `is` picks (in any branch).
fn reads_any(e: &Expr, is: &dyn Fn(&str) -> bool) -> bool {
    match e {
        Expr::Num(_) => false,
        Expr::Var(v) => is(v),
        Expr::Neg(a) => reads_any(a, is),
        Expr::Bin(_, a, b) => reads_any(a, is) || reads_any(b, is),
        Expr::Call(_, args) => args.iter().any(|a| reads_any(a, is)),
    }
}

impl Context<'_> {
    /// `s` parsed (a formula once per behaviour, [`ParsedFormulas`]); an error names `field`.
    fn parse(&self, field: &(impl FieldPath + ?Sized), s: &Scalar) -> Result<Arc<Expr>, SimError> {
        self.formulas.parse(s, || named(field, |f| s.parse(f)))
    }

    /// The gradient over the parameters of a number [`Self::number`] has checked (`q0`, the
    /// joint's start angle, an input: no gradient).
    fn grad(&self, s: &Scalar, q0: Option<f64>) -> Grad {
        if !self.tangent {
            return self.empty.clone();
        }
        let n = self.n;
        let e = self.parse("", s).expect("checked by `number`");
        let lookup = |name: &str| match name {
            "q0" => q0.map(|v| (v, vec![0.0; n])),
            _ => Some((
                *self.values.get(name)?,
                self.grads
                    .get(name)
                    .map_or_else(|| vec![0.0; n], |g| g.to_vec()),
            )),
        };
        let (_, d) = e.eval_grad(n, &lookup).expect("checked by `number`");
        d.into()
    }

    /// [`Self::number`] with its gradient.
    fn number_grad(
        &self,
        field: &(impl FieldPath + ?Sized),
        s: &Scalar,
        q0: Option<f64>,
    ) -> Result<(f64, Grad), SimError> {
        let v = self.number(field, s, q0)?;
        Ok((v, self.grad(s, q0)))
    }

    fn zero(&self) -> Grad {
        if !self.tangent {
            return self.empty.clone();
        }
        vec![0.0; self.n].into()
    }

    /// A number known now: `scalar` with the parameters (and `q0`, the joint's start angle,
    /// when given).
    fn number(
        &self,
        field: &(impl FieldPath + ?Sized),
        s: &Scalar,
        q0: Option<f64>,
    ) -> Result<f64, SimError> {
        let e = self.parse(field, s)?;
        let (v, _) = self.eval(field, s, &e, q0, false)?;
        named(field, |f| finite(f, v))
    }

    /// `e` with the parameters, `q0` where given, and `theta = omega = 0` when `at_start`
    /// (a motion's number, checked once now); an error names the first name `e` reads that
    /// is none of these. With the value, the names `e` reads and their values (`theta` and
    /// `omega` left out).
    fn eval<'e>(
        &self,
        field: &(impl FieldPath + ?Sized),
        s: &Scalar,
        e: &'e Expr,
        q0: Option<f64>,
        at_start: bool,
    ) -> Result<(f64, NamesRead<'e>), SimError> {
        let lookup = |v: &str| match v {
            "q0" => q0,
            "theta" | "omega" if at_start => Some(0.0),
            _ => {
                let x = self.values.get(v).copied();
                if let (Some(x), Some(log)) = (x, self.log.borrow_mut().as_mut()) {
                    log.push((v.to_string(), x.to_bits()));
                }
                x
            }
        };
        let mut read = Vec::new();
        names(e, &mut read);
        let mut reads = Vec::with_capacity(read.len());
        for v in read {
            let Some(x) = lookup(v) else {
                let extra = if v == "theta" || v == "omega" {
                    " (`theta` and `omega` exist only in the targets of motions)"
                } else {
                    ""
                };
                return Err(SimError::UnknownReference {
                    field: field.path(),
                    kind: "parameter",
                    name: v.to_string(),
                    known: format!(
                        "{}{extra}",
                        self.values.keys().cloned().collect::<Vec<_>>().join(", ")
                    ),
                });
            };
            reads.push((v, x));
        }
        let v = eval_read(e, &reads, field, &|| format!("{s:?}"))?;
        reads.retain(|(n, _)| !matches!(*n, "theta" | "omega"));
        Ok((v, reads))
    }

    /// A number of a motion: known now unless it uses `theta` or `omega`; with its tangent.
    /// One that does keeps the values of the other names it reads (and `q0`).
    fn motion_value(
        &self,
        field: &(impl FieldPath + ?Sized),
        s: &Scalar,
        q0: f64,
    ) -> Result<(Value, NumberTangent), SimError> {
        let e = self.parse(field, s)?;
        // checks names and evaluates once (at θ = ω = 0) to catch errors now
        let (v, reads) = self.eval(field, s, &e, Some(q0), true)?;
        let at_start = |n: &str| n == "theta" || n == "omega";
        if reads_any(&e, &at_start) {
            let consts: Vec<(String, f64)> =
                reads.into_iter().map(|(n, v)| (n.to_string(), v)).collect();
            let consts = Arc::new(consts);
            let tangent = if self.tangent {
                NumberTangent::AtStart(Arc::clone(&e), Arc::clone(&consts))
            } else {
                NumberTangent::Const(self.empty.clone())
            };
            Ok((Value::AtStart(e, consts), tangent))
        } else {
            Ok((
                Value::Const(named(field, |f| finite(f, v))?),
                NumberTangent::Const(self.grad(s, Some(q0))),
            ))
        }
    }

    /// `part()` and, when `record`, the names it read from [`Self::values`] with their
    /// values' bits (what [`Reused::holds`] checks).
    fn recording<T>(
        &self,
        record: bool,
        part: impl FnOnce() -> Result<T, SimError>,
    ) -> Result<Reused<T>, SimError> {
        let outer = record.then(|| self.log.replace(Some(Vec::new())));
        let value = part();
        let mut reads = match outer {
            Some(outer) => self.log.replace(outer).unwrap_or_default(),
            None => Vec::new(),
        };
        // each name once: what a reuse compares
        reads.sort_unstable();
        reads.dedup();
        Ok(Reused {
            value: value?,
            reads,
        })
    }

    fn contacts(&self, field: &str, names: &[String]) -> Result<u32, SimError> {
        let mut mask = 0u32;
        for (i, n) in names.iter().enumerate() {
            mask |= 1 << contact_by_name(self.model, n, &format!("{field}[{i}]"))?;
        }
        Ok(mask)
    }
}

/// A behaviour's parameters by name (its own, or values bound in their place:
/// [`compile_bound`]).
pub type Parameters = BTreeMap<String, Scalar>;

/// A parameter as [`parameters`] evaluates it: a number, or a parsed formula.
enum ParameterExpr {
    Number(f64),
    Formula(Arc<Expr>),
}

/// Evaluates the parameters in dependency order (a formula may use other parameters).
fn parameters(
    p: &Parameters,
    formulas: &ParsedFormulas,
) -> Result<BTreeMap<String, f64>, SimError> {
    // in name order (a `Parameters` map's own), found by binary search
    let names: Vec<&str> = p.keys().map(String::as_str).collect();
    let mut exprs = Vec::with_capacity(names.len());
    for (name, s) in p {
        if name.is_empty()
            || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
            || name.starts_with(|c: char| c.is_ascii_digit())
            || matches!(name.as_str(), "theta" | "omega" | "q0")
        {
            return Err(invalid(
                Leaf("parameters", name).path(),
                "a parameter name is letters, digits and `_`, not starting with a digit, and not \
                 `theta`, `omega` or `q0`",
            ));
        }
        exprs.push(match s {
            Scalar::Number(x) => ParameterExpr::Number(*x),
            Scalar::Expr(_) => ParameterExpr::Formula(
                formulas.parse(s, || named(&Leaf("parameters", name), |f| s.parse(f)))?,
            ),
        });
    }
    let mut values = vec![None; names.len()];
    for i in 0..names.len() {
        visit_parameter(i, (&names, &exprs), &mut values, &mut Vec::new())?;
    }
    Ok(names
        .iter()
        .zip(values)
        .map(|(n, v)| (n.to_string(), v.expect("every parameter visited")))
        .collect())
}

/// The value of parameter `i` of `keys` (with its expression in `exprs`), evaluated
/// depth-first into `values` after those its formula reads, with the path so far (`path`) to
/// report a cycle.
fn visit_parameter(
    i: usize,
    (keys, exprs): (&[&str], &[ParameterExpr]),
    values: &mut [Option<f64>],
    path: &mut Vec<usize>,
) -> Result<f64, SimError> {
    if let Some(v) = values[i] {
        return Ok(v);
    }
    let name = keys[i];
    let field = Leaf("parameters", name);
    if let Some(at) = path.iter().position(|&p| p == i) {
        let mut cycle: Vec<String> = path[at..].iter().map(|&p| keys[p].to_string()).collect();
        cycle.push(name.to_string());
        return Err(SimError::Cycle {
            field: Leaf("parameters", keys[path[at]]).path(),
            cycle,
        });
    }
    if path.len() >= MAX_PARAMETER_CHAIN {
        return Err(invalid(
            field.path(),
            format!("its formula starts a chain of more than {MAX_PARAMETER_CHAIN} parameters using each other"),
        ));
    }
    let v = match &exprs[i] {
        ParameterExpr::Number(x) => *x,
        ParameterExpr::Formula(e) => {
            path.push(i);
            let mut read = Vec::new();
            names(e, &mut read);
            let mut local = Vec::with_capacity(read.len());
            for v in read {
                let Ok(k) = keys.binary_search(&v) else {
                    return Err(SimError::UnknownReference {
                        field: field.path(),
                        kind: "parameter",
                        name: v.to_string(),
                        known: keys.join(", "),
                    });
                };
                local.push((v, visit_parameter(k, (keys, exprs), values, path)?));
            }
            path.pop();
            eval_read(e, &local, &field, &|| format!("{e:?}"))?
        }
    };
    let v = named(&field, |f| finite(f, v))?;
    values[i] = Some(v);
    Ok(v)
}

/// The gradient of every parameter over the parameters, in name order: `e_p` plus the chain
/// of its formula (the parameters have been evaluated and checked for cycles).
fn parameter_grads(
    p: &Parameters,
    values: &BTreeMap<String, f64>,
    formulas: &ParsedFormulas,
) -> BTreeMap<String, Grad> {
    fn visit(
        name: &str,
        p: &Parameters,
        values: &BTreeMap<String, f64>,
        grads: &mut BTreeMap<String, Grad>,
        formulas: &ParsedFormulas,
    ) -> Grad {
        if let Some(g) = grads.get(name) {
            return g.clone();
        }
        let n = p.len();
        let e = formulas
            .parse(&p[name], || p[name].parse(""))
            .expect("parsed by `parameters`");
        let mut vars = Vec::new();
        e.variables(&mut vars);
        let deps: BTreeMap<String, Grad> = vars
            .iter()
            .map(|v| (v.clone(), visit(v, p, values, grads, formulas)))
            .collect();
        let (_, mut d) = e
            .eval_grad(n, &|v| Some((values[v], deps.get(v)?.to_vec())))
            .expect("evaluated by `parameters`");
        let i = p.keys().position(|k| k == name).expect("a parameter");
        d[i] += 1.0;
        let g: Grad = d.into();
        grads.insert(name.to_string(), g.clone());
        g
    }
    let mut grads = BTreeMap::new();
    for name in p.keys() {
        visit(name, p, values, &mut grads, formulas);
    }
    grads
}

/// `(quantity, value, gradient)` of what an actuator's data give besides its stall torque
/// ([`actuator`]).
type DerivedQuantities = Vec<(&'static str, f64, Grad)>;

/// An actuator of the spec, and the quantities derived from its data that expressions may
/// read as `<name>.<quantity>` besides its stall torque: for DC motors their no-load output
/// speed `no_load_speed_rad_s` (`ω₀ / G`) and, when the catalog prints the motor's mechanical
/// time constant `τ_m`, the rotors' inertia reflected to the joint,
/// `reflected_inertia_kg_m2 = n J G²` with `J = τ_m k_M² / R` (the rotor inertia the time
/// constant implies, from the catalog's motor at its rated voltage).
fn actuator(
    cx: &Context<'_>,
    field: &str,
    spec: &ActuatorSpec,
) -> Result<(Arc<dyn Actuator>, DerivedQuantities, ActuatorLaw), SimError> {
    let motor_err = |f: &'static str| {
        move |e: motor::MotorError| SimError::Motor {
            field: Leaf(field, f).path(),
            source: e,
        }
    };
    let positive_number = |f: &'static str, s: &Scalar| -> Result<f64, SimError> {
        let v = cx.number(&Leaf(field, f), s, None)?;
        named(&Leaf(field, f), |path| positive(path, v))
    };
    Ok(match spec {
        ActuatorSpec::Saturated { max_torque_n_m } => {
            let tau = positive_number("max_torque_n_m", max_torque_n_m)?;
            let a: Arc<dyn Actuator> =
                Arc::new(motor::SaturatedTorque::new(tau).map_err(motor_err("max_torque_n_m"))?);
            let law = ActuatorLaw::Saturated {
                max_n_m: tau,
                dmax: cx.grad(max_torque_n_m, None),
            };
            (a, Vec::new(), law)
        }
        ActuatorSpec::DcMotor {
            motor: motor_name,
            gearbox,
            gear_ratio,
            current_limit_a,
            supply_voltage_v,
            count,
            catalog,
            gearbox_efficiency,
            gearbox_loss,
            battery_resistance_ohm,
        } => {
            let catalog = match catalog {
                None => motor::Catalog::thesis(),
                Some(path) => {
                    let text = super::spec::read_text(std::path::Path::new(path))?;
                    motor::Catalog::from_toml_str(&text).map_err(motor_err("catalog"))?
                }
            };
            let motor_spec = catalog.motor_spec(motor_name).map_err(motor_err("motor"))?;
            let mut m = motor_spec.motor().map_err(motor_err("motor"))?;
            let grad = |s: &Option<crate::expr::Scalar>| {
                s.as_ref().map_or(cx.zero(), |s| cx.grad(s, None))
            };
            if let Some(v) = supply_voltage_v {
                let v = positive_number("supply_voltage_v", v)?;
                m = m.at_voltage(v).map_err(motor_err("supply_voltage_v"))?;
            }
            if let Some(i) = current_limit_a {
                let i = positive_number("current_limit_a", i)?;
                m = m
                    .with_current_limit(i)
                    .map_err(motor_err("current_limit_a"))?;
            }
            let mut g = catalog
                .gearbox(gearbox)
                .map_err(motor_err("gearbox"))?
                .clone();
            if let Some(r) = gear_ratio {
                g.ratio = positive_number("gear_ratio", r)?;
            }
            if let Some(e) = gearbox_efficiency {
                g.efficiency = positive_number("gearbox_efficiency", e)?;
                if g.efficiency > 1.0 {
                    return Err(invalid(
                        Leaf(field, "gearbox_efficiency").path(),
                        format!("must be at most 1, got {}", g.efficiency),
                    ));
                }
            }
            let losses = motor::DriveLosses {
                gearbox_loss: *gearbox_loss,
                battery_resistance_ohm: match battery_resistance_ohm {
                    Some(r) => cx.number(&Leaf(field, "battery_resistance_ohm"), r, None)?,
                    None => 0.0,
                },
            };
            let n = cx.number(&Leaf(field, "count"), count, None)?;
            if !(n >= 1.0 && n.fract() == 0.0) {
                return Err(invalid(
                    Leaf(field, "count").path(),
                    format!("must be a whole number ≥ 1, got {n}"),
                ));
            }
            let ratio = g.ratio;
            let law = ActuatorLaw::Geared(GearedLaw {
                n,
                ratio,
                efficiency: g.efficiency,
                stall_n_m: m.stall_torque_n_m,
                no_load_rad_s: m.no_load_speed_rad_s,
                torque_constant_n_m_per_a: m.torque_constant_n_m_per_a,
                current_limit_a: m.current_limit_a,
                voltage_v: m.supply_voltage_v,
                losses: GearedLosses {
                    power_flow: losses.gearbox_loss == motor::GearboxLoss::PowerFlow,
                    battery_resistance_ohm: losses.battery_resistance_ohm,
                    terminal_resistance_ohm: m.terminal_resistance_ohm(),
                },
                dn: cx.grad(count, None),
                dratio: grad(gear_ratio),
                dcurrent: grad(current_limit_a),
                dvoltage: grad(supply_voltage_v),
                defficiency: grad(gearbox_efficiency),
                dbattery: grad(battery_resistance_ohm),
            });
            let speed = m.no_load_speed_rad_s / ratio;
            // gradients only where the tangent is built (`compile_shared`)
            let grad_of = |g: &dyn Fn() -> Grad| if cx.tangent { g() } else { cx.empty.clone() };
            let mut derived = vec![(
                "no_load_speed_rad_s",
                speed,
                grad_of(&|| law.no_load_speed_grad()),
            )];
            if let Some(rotor) = motor_spec
                .rotor_inertia_kg_m2()
                .map_err(motor_err("motor"))?
            {
                let inertia = n * rotor * ratio * ratio;
                derived.push((
                    "reflected_inertia_kg_m2",
                    inertia,
                    grad_of(&|| law.reflected_inertia_grad(rotor)),
                ));
            }
            let drive = motor::Drive::new(m, g)
                .map_err(motor_err("gearbox"))?
                .with_losses(losses)
                .map_err(motor_err("battery_resistance_ohm"))?;
            // the law is chosen here, once: the thesis's (the default options) reads no
            // option per call
            let a: Arc<dyn Actuator> = if losses == motor::DriveLosses::default() {
                Arc::new(Drives::<false> { drive, n })
            } else {
                Arc::new(Drives::<true> { drive, n })
            };
            (a, derived, law)
        }
    })
}

/// `n` identical drives in parallel on one joint, `LOSSY` with the drive's loss options
/// (`motor::DriveLosses`), else the thesis's law, which reads none of them per call (bit for
/// bit the same where the options are the defaults).
pub struct Drives<const LOSSY: bool> {
    pub drive: motor::Drive,
    pub n: f64,
}

impl Actuator for Drives<false> {
    fn joint_torque_n_m(&self, command: f64, speed: f64) -> f64 {
        self.n * self.drive.derated_output_torque_n_m(command, speed)
    }
    fn electrical_power_w(&self, command: f64, speed: f64) -> f64 {
        self.n * self.drive.ideal_supply_power_w(command, speed)
    }
}

impl Actuator for Drives<true> {
    fn joint_torque_n_m(&self, command: f64, speed: f64) -> f64 {
        self.n * self.drive.joint_torque_n_m(command, speed)
    }
    fn electrical_power_w(&self, command: f64, speed: f64) -> f64 {
        self.n * self.drive.electrical_power_w(command, speed)
    }
}

/// A trigger's kind of event, or an error if it is not an event.
fn event_kind(field: &str, on: On) -> Result<MatchKind, SimError> {
    Ok(match on {
        On::Touchdown => MatchKind::Kind(EventKind::Touchdown),
        On::Liftoff => MatchKind::Kind(EventKind::Liftoff),
        On::Slip => MatchKind::Kind(EventKind::Slip),
        On::Stick => MatchKind::Kind(EventKind::Stick),
        On::Apex => MatchKind::Kind(EventKind::Apex),
        On::Release => MatchKind::Release,
        On::Touch => MatchKind::Touch,
        On::Flight => MatchKind::Flight,
        On::Any => MatchKind::Any,
        On::JointAngle | On::Phase => {
            return Err(invalid(
                format!("{field}.on"),
                "`joint_angle` and `phase` are not events: use them to start a phase",
            ))
        }
    })
}

/// The gradients of a start's times and delays, in the order of `Start::times` and
/// `Start::phases`.
#[derive(Default)]
struct StartGrads {
    times: Vec<Grad>,
    delays: Vec<Grad>,
}

/// Where a phase reference points: `(program, phase)`.
type PhaseRef = (usize, usize);

/// The names an expression reads, with their values.
type NamesRead<'e> = Vec<(&'e str, f64)>;

/// A compiled joint program, its phases' tangents, and its phases as recorded for reuse.
type CompiledProgram = (Program, Vec<PhaseTangent>, Vec<Reused<PhasePlan>>);

struct Compiler<'a> {
    cx: Context<'a>,
    named: &'a [String],
    /// `(joint name, phase names)` of every program, for phase references.
    programs: &'a [(String, Vec<String>)],
}

impl Compiler<'_> {
    fn event_match(
        &self,
        field: &str,
        on: On,
        contacts: &Option<Vec<String>>,
        not_before_s: &Option<Scalar>,
        own: u32,
        q0: Option<f64>,
    ) -> Result<EventMatch, SimError> {
        let kind = event_kind(field, on)?;
        let contacts = match contacts {
            Some(names) => self.cx.contacts(&format!("{field}.contacts"), names)?,
            None => own,
        };
        let not_before_s = match not_before_s {
            Some(s) => self.cx.number(&Leaf(field, "not_before_s"), s, q0)?,
            None => f64::NEG_INFINITY,
        };
        Ok(EventMatch {
            kind,
            contacts,
            not_before_s,
        })
    }

    fn named_index(&self, field: &str, name: &str) -> Result<usize, SimError> {
        self.named
            .iter()
            .position(|n| n == name)
            .ok_or_else(|| SimError::UnknownReference {
                field: field.into(),
                kind: "event",
                name: name.into(),
                known: self.named.join(", "),
            })
    }

    fn phase_ref(&self, field: &str, name: &str) -> Result<PhaseRef, SimError> {
        let unknown = || SimError::UnknownReference {
            field: field.into(),
            kind: "phase",
            name: name.into(),
            known: self
                .programs
                .iter()
                .flat_map(|(j, ps)| ps.iter().map(move |p| format!("{j}.{p}")))
                .collect::<Vec<_>>()
                .join(", "),
        };
        let (joint, phase) = name.rsplit_once('.').ok_or_else(unknown)?;
        let p = self
            .programs
            .iter()
            .position(|(j, _)| j == joint)
            .ok_or_else(unknown)?;
        let k = self.programs[p]
            .1
            .iter()
            .position(|n| n == phase)
            .ok_or_else(unknown)?;
        Ok((p, k))
    }

    /// Adds the alternatives of `t` to `start` (and the gradients of its times and delays to
    /// `grads`).
    #[allow(clippy::too_many_arguments)]
    fn start(
        &self,
        field: &str,
        t: &Trigger,
        (start, grads): (&mut Start, &mut StartGrads),
        own_joint: usize,
        own: u32,
        q0: f64,
        nested: bool,
    ) -> Result<(), SimError> {
        let set = [
            t.at_s.is_some(),
            t.on.is_some(),
            t.event.is_some(),
            t.any.is_some(),
        ];
        if set.iter().filter(|&&b| b).count() != 1 {
            return Err(invalid(
                field,
                "give exactly one of `at_s`, `on`, `event`, `any`",
            ));
        }
        // the fields a kind of trigger reads; any other one given is an error naming it
        let only = |allowed: &[&str]| -> Result<(), SimError> {
            let given = [
                ("contacts", t.contacts.is_some()),
                ("not_before_s", t.not_before_s.is_some()),
                ("joint", t.joint.is_some()),
                ("angle_rad", t.angle_rad.is_some()),
                ("direction", t.direction.is_some()),
                ("phase", t.phase.is_some()),
                ("delay_s", t.delay_s.is_some()),
            ];
            match given.iter().find(|(n, g)| *g && !allowed.contains(n)) {
                Some((n, _)) => Err(invalid(
                    format!("{field}.{n}"),
                    "does not apply to this kind of trigger",
                )),
                None => Ok(()),
            }
        };
        if let Some(at) = &t.at_s {
            only(&[])?;
            let (v, g) = self.cx.number_grad(&Leaf(field, "at_s"), at, Some(q0))?;
            start.times.push(v);
            grads.times.push(g);
        } else if let Some(name) = &t.event {
            only(&[])?;
            start
                .named
                .push(self.named_index(&format!("{field}.event"), name)?);
        } else if let Some(list) = &t.any {
            if list.is_empty() {
                return Err(invalid(format!("{field}.any"), "must not be empty"));
            }
            for (i, sub) in list.iter().enumerate() {
                self.start(
                    &format!("{field}.any[{i}]"),
                    sub,
                    (&mut *start, &mut *grads),
                    own_joint,
                    own,
                    q0,
                    true,
                )?;
            }
        } else if let Some(on) = t.on {
            match on {
                On::JointAngle => {
                    if nested {
                        return Err(invalid(
                            format!("{field}.on"),
                            "a joint-angle level cannot be one of several alternatives",
                        ));
                    }
                    only(&["joint", "angle_rad", "direction"])?;
                    let joint = match &t.joint {
                        None => own_joint,
                        Some(name) => joint_index(self.cx.model, name).ok_or_else(|| {
                            SimError::UnknownJoint {
                                field: format!("{field}.joint"),
                                name: name.clone(),
                                known: known_joints(self.cx.model),
                            }
                        })?,
                    };
                    let f = format!("{field}.angle_rad");
                    let angle = match &t.angle_rad {
                        Some(a) => self.cx.number(&f, a, Some(q0))?,
                        None => return Err(invalid(f, "is required for `joint_angle`")),
                    };
                    let f = format!("{field}.direction");
                    let direction = match &t.direction {
                        Some(d) => self.cx.number(&f, d, Some(q0))?,
                        None => 1.0,
                    };
                    if direction != 1.0 && direction != -1.0 {
                        return Err(invalid(f, format!("must be +1 or -1, got {direction}")));
                    }
                    start.level = Some(Level {
                        joint,
                        direction,
                        angle,
                    });
                }
                On::Phase => {
                    only(&["phase", "delay_s"])?;
                    let f = format!("{field}.phase");
                    let name = t
                        .phase
                        .as_ref()
                        .ok_or_else(|| invalid(f.clone(), "is required for `phase`"))?;
                    let (p, k) = self.phase_ref(&f, name)?;
                    let f = format!("{field}.delay_s");
                    let (delay, g) = match &t.delay_s {
                        Some(d) => {
                            let (v, g) = self.cx.number_grad(&f, d, Some(q0))?;
                            (non_negative(&f, v)?, g)
                        }
                        None => (0.0, self.cx.zero()),
                    };
                    start.phases.push((p, k, delay));
                    grads.delays.push(g);
                }
                _ => {
                    only(&["contacts", "not_before_s"])?;
                    start.events.push(self.event_match(
                        field,
                        on,
                        &t.contacts,
                        &t.not_before_s,
                        own,
                        Some(q0),
                    )?);
                }
            }
        }
        Ok(())
    }

    fn torque(
        &self,
        field: &(impl FieldPath + ?Sized),
        t: &Torque,
        q0: f64,
        actuators: &[String],
    ) -> Result<(TorqueLaw, TorqueTangent), SimError> {
        let num = |f: &str, s: &Scalar| self.cx.number(&Leaf(field, f), s, Some(q0));
        let grad = |s: &Scalar| self.cx.grad(s, Some(q0));
        Ok(match t {
            Torque::Zero => (TorqueLaw::Zero, TorqueTangent::Zero),
            Torque::Constant { torque_n_m } => (
                TorqueLaw::Constant(num("torque_n_m", torque_n_m)?),
                TorqueTangent::Constant(grad(torque_n_m)),
            ),
            Torque::Schedule {
                times_s,
                torques_n_m,
                interpolation,
            } => {
                if times_s.is_empty() || times_s.len() != torques_n_m.len() {
                    return Err(invalid(
                        format!("{field}.torques_n_m"),
                        format!(
                            "needs one torque per time and at least one ({} times, {} torques)",
                            times_s.len(),
                            torques_n_m.len()
                        ),
                    ));
                }
                let times = times_s
                    .iter()
                    .enumerate()
                    .map(|(i, s)| num(&format!("times_s[{i}]"), s))
                    .collect::<Result<Vec<_>, _>>()?;
                if times.windows(2).any(|w| w[1] <= w[0]) {
                    return Err(invalid(
                        format!("{field}.times_s"),
                        "times must increase strictly",
                    ));
                }
                let torques = torques_n_m
                    .iter()
                    .enumerate()
                    .map(|(i, s)| num(&format!("torques_n_m[{i}]"), s))
                    .collect::<Result<Vec<_>, _>>()?;
                (
                    TorqueLaw::Schedule {
                        times,
                        torques,
                        hold: *interpolation == Interpolation::Hold,
                    },
                    TorqueTangent::Schedule {
                        times: times_s.iter().map(grad).collect(),
                        torques: torques_n_m.iter().map(grad).collect(),
                    },
                )
            }
            Torque::Servo {
                target_rad,
                kp_n_m_per_rad,
                kd_n_m_s_per_rad,
                torque_limit_n_m,
                only_in_contact,
            } => {
                let nn = |f: &str, s: &Scalar| -> Result<f64, SimError> {
                    let v = num(f, s)?;
                    named(&Leaf(field, f), |path| non_negative(path, v))
                };
                (
                    TorqueLaw::Servo(ServoLaw {
                        target: target_rad
                            .as_ref()
                            .map(|s| num("target_rad", s))
                            .transpose()?,
                        kp: nn("kp_n_m_per_rad", kp_n_m_per_rad)?,
                        kd: nn("kd_n_m_s_per_rad", kd_n_m_s_per_rad)?,
                        limit: match torque_limit_n_m {
                            Some(s) => nn("torque_limit_n_m", s)?,
                            None => f64::INFINITY,
                        },
                        only_in_contact: *only_in_contact,
                    }),
                    TorqueTangent::Servo {
                        target: target_rad.as_ref().map(grad),
                        kp: grad(kp_n_m_per_rad),
                        kd: grad(kd_n_m_s_per_rad),
                        limit: torque_limit_n_m
                            .as_ref()
                            .map_or_else(|| self.cx.zero(), grad),
                    },
                )
            }
            Torque::Motor {
                actuator,
                command,
                reverse_beyond_rad,
            } => {
                let a = actuators
                    .iter()
                    .position(|n| n == actuator)
                    .ok_or_else(|| SimError::UnknownReference {
                        field: format!("{field}.actuator"),
                        kind: "actuator",
                        name: actuator.clone(),
                        known: actuators.join(", "),
                    })?;
                let u = num("command", command)?;
                if !(-1.0..=1.0).contains(&u) {
                    return Err(invalid(
                        format!("{field}.command"),
                        format!("must lie in [-1, 1], got {u}"),
                    ));
                }
                (
                    TorqueLaw::Motor {
                        actuator: a,
                        command: u,
                        reverse_beyond: reverse_beyond_rad
                            .as_ref()
                            .map(|s| num("reverse_beyond_rad", s))
                            .transpose()?,
                    },
                    TorqueTangent::Motor {
                        command: grad(command),
                    },
                )
            }
        })
    }

    /// The motion law, and the tangents of its numbers in the order `speed`, `accel`,
    /// `target` (a hold's angle its target; absent numbers constant).
    fn motion(
        &self,
        field: &(impl FieldPath + ?Sized),
        m: &Motion,
        q0: f64,
    ) -> Result<(MotionLaw, [NumberTangent; 3]), SimError> {
        let v = |f: &str, s: &Scalar| self.cx.motion_value(&Leaf(field, f), s, q0);
        // a speed or acceleration: positive, and small enough that the free joints' tracking
        // law, which differences two of them (`selfmanip_hybrid::free_joints`), stays finite
        let pos = |f: &str, s: &Scalar| -> Result<(Value, NumberTangent), SimError> {
            let val = v(f, s)?;
            if let Value::Const(x) = val.0 {
                named(&Leaf(field, f), |path| positive(path, x))?;
                named(&Leaf(field, f), |path| differenceable(path, x))?;
            }
            Ok(val)
        };
        let none = || NumberTangent::Const(self.cx.zero());
        Ok(match m {
            Motion::Hold { angle_rad } => {
                let (angle, d) = v("angle_rad", angle_rad)?;
                (MotionLaw::Hold { angle }, [none(), none(), d])
            }
            Motion::Swing {
                target_rad,
                speed_rad_s,
                accel_rad_s2,
            } => {
                let (target, dt) = v("target_rad", target_rad)?;
                let (speed, ds) = pos("speed_rad_s", speed_rad_s)?;
                let (accel, da) = pos("accel_rad_s2", accel_rad_s2)?;
                (
                    MotionLaw::Swing {
                        target,
                        speed,
                        accel,
                    },
                    [ds, da, dt],
                )
            }
            Motion::Park {
                target_rad,
                accel_rad_s2,
            } => {
                let (target, dt) = v("target_rad", target_rad)?;
                let (accel, da) = pos("accel_rad_s2", accel_rad_s2)?;
                (MotionLaw::Park { target, accel }, [none(), da, dt])
            }
        })
    }

    /// Program `i` (`prog`, of joint `j`, its phases in order), when the tangent is built its
    /// phases' tangents, and when `record` its phases with the names each read (for
    /// [`ReusableParts`]). A phase of `reuse` is taken as kept where the names it read have
    /// the same values and what it carries over from the phase before (its motion, its
    /// restarts) was kept too.
    fn program(
        &self,
        (i, j): (usize, usize),
        prog: &JointProgram,
        q0: &[f64],
        (remap, actuator_names): (&[usize], &[String]),
        (reuse, record): (Option<&[Reused<PhasePlan>]>, bool),
    ) -> Result<CompiledProgram, SimError> {
        let own = joint_contacts(self.cx.model, j);
        let mut phases: Vec<PhasePlan> = Vec::with_capacity(prog.phases.len());
        let mut tangents: Vec<PhaseTangent> = Vec::new();
        let mut recorded = Vec::new();
        let mut previous_kept = false;
        for (k, ph) in prog.phases.iter().enumerate() {
            let carries = k > 0 && (ph.motion.is_none() || ph.restart_on.is_none());
            let kept = reuse
                .and_then(|r| r.get(k))
                .filter(|r| (!carries || previous_kept) && r.holds(&self.cx.values));
            previous_kept = kept.is_some();
            let (phase, tangent) = match kept {
                Some(r) => (r.value.clone(), self.untangled_phase()),
                None => {
                    let prev = phases.last().zip(tangents.last());
                    let compiled = self.cx.recording(record, || {
                        self.phase((i, k), ph, (j, own, q0[j]), (remap, actuator_names), prev)
                    })?;
                    let (phase, tangent) = compiled.value;
                    if record {
                        recorded.push(Reused {
                            value: phase.clone(),
                            reads: compiled.reads,
                        });
                    }
                    (phase, tangent)
                }
            };
            phases.push(phase);
            if !self.cx.tangent {
                // the previous phase's motion tangent is read from here (`motion: None`)
                tangents.clear();
            }
            tangents.push(tangent);
        }
        let repeat_from = repeat_from(i, prog, &phases)?;
        Ok((
            Program {
                joint: j,
                contacts: own,
                has_levels: phases.iter().any(|ph| ph.start.level.is_some()),
                has_servo_manifold: phases.iter().any(|ph| servo_manifold(ph).is_some()),
                phases,
                repeat_from,
            },
            tangents,
            recorded,
        ))
    }

    /// The tangent of a phase compiled without gradients: no times, no delays, a zero torque
    /// and a motion of empty gradients (what [`Self::phase`] gives when the tangent is not
    /// built).
    fn untangled_phase(&self) -> PhaseTangent {
        let none = || NumberTangent::Const(self.cx.empty.clone());
        PhaseTangent {
            times: Vec::new(),
            delays: Vec::new(),
            torque: TorqueTangent::Zero,
            motion: [none(), none(), none()],
        }
    }

    /// Phase `k` of program `i` (`ph`, of joint `j` with the contacts `own`, starting at
    /// `q0j`) and its tangent, after the phase `prev` (with its tangent) whose motion and
    /// restarts it keeps where it has none of its own.
    fn phase(
        &self,
        (i, k): (usize, usize),
        ph: &Phase,
        (j, own, q0j): (usize, u32, f64),
        (remap, actuator_names): (&[usize], &[String]),
        prev: Option<(&PhasePlan, &PhaseTangent)>,
    ) -> Result<(PhasePlan, PhaseTangent), SimError> {
        let field = format!("joints[{i}].phases[{k}]");
        let mut start = Start::default();
        let mut start_grads = StartGrads::default();
        match (&ph.start, k) {
            (Some(_), 0) => {
                return Err(invalid(
                    format!("{field}.start"),
                    "the first phase holds from the start: it has no `start`",
                ))
            }
            (None, 0) => {}
            (None, _) => {
                return Err(invalid(
                    format!("{field}.start"),
                    "is required after the first phase",
                ))
            }
            (Some(t), _) => self.start(
                &format!("{field}.start"),
                t,
                (&mut start, &mut start_grads),
                j,
                own,
                q0j,
                false,
            )?,
        }
        for n in &mut start.named {
            *n = remap[*n];
        }
        let (torque, torque_tangent) = self.torque(
            &Leaf(field.as_str(), "torque"),
            &ph.torque,
            q0j,
            actuator_names,
        )?;
        let ((motion, motion_tangent), own_motion) = match (&ph.motion, prev) {
            (Some(m), _) => (self.motion(&Leaf(field.as_str(), "motion"), m, q0j)?, true),
            (None, Some((prev, prev_tangent))) => {
                ((prev.motion.clone(), prev_tangent.motion.clone()), false)
            }
            (None, None) => {
                let none = || NumberTangent::Const(self.cx.zero());
                (
                    (
                        MotionLaw::Hold {
                            angle: Value::Const(q0j),
                        },
                        [none(), none(), none()],
                    ),
                    true,
                )
            }
        };
        let (restart_on, restart_named) = match (&ph.restart_on, prev) {
            (Some(list), _) => {
                let mut events = Vec::new();
                let mut names = Vec::new();
                for (r, t) in list.iter().enumerate() {
                    let f = format!("{field}.restart_on[{r}]");
                    let mut s = Start::default();
                    let mut unused = StartGrads::default();
                    self.start(&f, t, (&mut s, &mut unused), j, own, q0j, true)?;
                    if !s.times.is_empty() || !s.phases.is_empty() {
                        return Err(invalid(
                            f,
                            "a motion restarts at events (`on`, `event`, `any`), not at times or phases",
                        ));
                    }
                    events.extend(s.events);
                    names.extend(s.named.iter().map(|&n| remap[n]));
                }
                (events, names)
            }
            (None, Some((prev, _))) => (prev.restart_on.clone(), prev.restart_named.clone()),
            (None, None) => (Vec::new(), Vec::new()),
        };
        let phase = PhasePlan {
            name: ph.name.clone(),
            start,
            torque,
            motion,
            own_motion,
            restart_on,
            restart_named,
        };
        let tangent = if self.cx.tangent {
            PhaseTangent {
                times: start_grads.times,
                delays: start_grads.delays,
                torque: torque_tangent,
                motion: motion_tangent,
            }
        } else {
            PhaseTangent {
                times: Vec::new(),
                delays: Vec::new(),
                torque: TorqueTangent::Zero,
                motion: motion_tangent,
            }
        };
        Ok((phase, tangent))
    }

    fn named_event(&self, name: &str, ev: &NamedEvent) -> Result<NamedPlan, SimError> {
        let field = format!("events.{name}");
        let trigger = self.event_match(
            &field,
            ev.on,
            &ev.contacts,
            &ev.not_before_s,
            u32::MAX,
            None,
        )?;
        let after = ev
            .after_event
            .as_ref()
            .map(|a| self.named_index(&format!("{field}.after_event"), a))
            .transpose()?;
        Ok(NamedPlan {
            name: name.into(),
            trigger,
            after,
        })
    }
}

/// The order in which named events are checked (each after the one it waits for), or the
/// cycle.
fn named_order(b: &Behaviour, names: &[String]) -> Result<Vec<usize>, SimError> {
    let after: Vec<Option<usize>> = names
        .iter()
        .map(|n| {
            b.events[n]
                .after_event
                .as_ref()
                .and_then(|a| names.iter().position(|x| x == a))
        })
        .collect();
    let mut order = Vec::new();
    for start in 0..names.len() {
        let mut path: Vec<usize> = Vec::new();
        let mut n = start;
        loop {
            if order.contains(&n) {
                break;
            }
            if let Some(i) = path.iter().position(|&p| p == n) {
                let mut cycle: Vec<String> = path[i..]
                    .iter()
                    .map(|&p: &usize| names[p].clone())
                    .collect();
                cycle.push(names[n].clone());
                return Err(SimError::Cycle {
                    field: format!("events.{}.after_event", names[n]),
                    cycle,
                });
            }
            path.push(n);
            match after[n] {
                Some(a) => n = a,
                None => break,
            }
        }
        for &p in path.iter().rev() {
            if !order.contains(&p) {
                order.push(p);
            }
        }
    }
    Ok(order)
}

/// Refuses phases that can only start after phases that can only start after them (a
/// deadlock): an edge `X → Y` when `X` starts on nothing but phase references, one of them
/// to `Y`.
fn check_phase_cycles(
    programs: &[Program],
    names: &[(String, Vec<String>)],
) -> Result<(), SimError> {
    let only_refs = |(p, k): PhaseRef| -> Vec<PhaseRef> {
        let s = &programs[p].phases[k].start;
        if s.times.is_empty() && s.events.is_empty() && s.named.is_empty() && s.level.is_none() {
            s.phases.iter().map(|&(p2, k2, _)| (p2, k2)).collect()
        } else {
            Vec::new()
        }
    };
    let label = |(p, k): PhaseRef| format!("{}.{}", names[p].0, names[p].1[k]);
    for (p, prog) in programs.iter().enumerate() {
        for k in 1..prog.phases.len() {
            // depth-first from (p, k) along phase-only waits, looking for (p, k) again
            let mut stack = vec![vec![(p, k)]];
            let mut seen = vec![(p, k)];
            while let Some(path) = stack.pop() {
                for d in only_refs(*path.last().expect("non-empty")) {
                    if d == (p, k) {
                        let mut cycle: Vec<String> = path.iter().map(|&x| label(x)).collect();
                        cycle.push(label(d));
                        return Err(SimError::Cycle {
                            field: format!("joints[{p}].phases[{k}].start"),
                            cycle,
                        });
                    }
                    if !seen.contains(&d) {
                        seen.push(d);
                        let mut next = path.clone();
                        next.push(d);
                        stack.push(next);
                    }
                }
            }
        }
    }
    Ok(())
}

/// Each program's `(joint name, phase names)` and the program of each joint, checked: joints
/// that exist and have one program, phases with distinct non-empty names, at least one.
type ProgramNames = (Vec<(String, Vec<String>)>, Vec<Option<usize>>);

fn program_names(b: &Behaviour, model: &Model) -> Result<ProgramNames, SimError> {
    let mut programs_names = Vec::new();
    let mut program_of_joint = vec![None; model.n_joints()];
    for (i, prog) in b.joints.iter().enumerate() {
        let field = format!("joints[{i}].joint");
        let j = joint_index(model, &prog.joint).ok_or_else(|| SimError::UnknownJoint {
            field: field.clone(),
            name: prog.joint.clone(),
            known: known_joints(model),
        })?;
        if program_of_joint[j].is_some() {
            return Err(invalid(
                field,
                format!("joint `{}` has two programs", prog.joint),
            ));
        }
        program_of_joint[j] = Some(i);
        let mut phase_names: Vec<String> = Vec::new();
        for (k, ph) in prog.phases.iter().enumerate() {
            if phase_names.contains(&ph.name) || ph.name.is_empty() {
                return Err(invalid(
                    format!("joints[{i}].phases[{k}].name"),
                    "phase names must be non-empty and distinct",
                ));
            }
            phase_names.push(ph.name.clone());
        }
        if prog.phases.is_empty() {
            return Err(invalid(
                format!("joints[{i}].phases"),
                "needs at least one phase",
            ));
        }
        programs_names.push((prog.joint.clone(), phase_names));
    }
    Ok((programs_names, program_of_joint))
}

/// The phase program `i` repeats from, checked (after the first, not a joint-angle level).
fn repeat_from(
    i: usize,
    prog: &JointProgram,
    phases: &[PhasePlan],
) -> Result<Option<usize>, SimError> {
    Ok(match &prog.repeat_from {
        None => None,
        Some(name) => {
            let f = format!("joints[{i}].repeat_from");
            let r = phases
                .iter()
                .position(|ph| &ph.name == name)
                .ok_or_else(|| SimError::UnknownReference {
                    field: f.clone(),
                    kind: "phase",
                    name: name.clone(),
                    known: phases
                        .iter()
                        .map(|ph| ph.name.clone())
                        .collect::<Vec<_>>()
                        .join(", "),
                })?;
            if r == 0 || phases[r].start.level.is_some() {
                return Err(invalid(
                    f,
                    "a program repeats from a phase after the first that is not a joint-angle level",
                ));
            }
            Some(r)
        }
    })
}

/// The behaviour's actuators and their torque laws. Their stall torques as parameters
/// `<name>.stall_torque_n_m`, with what else their data give ([`actuator`]), join the values
/// of `cx` (and their gradients, with the tangent): every actuator reads the parameters
/// alone.
/// The actuators of a behaviour and the quantities they give its formulas (`leg.stall_torque_n_m`,
/// inserted into the context's values too).
type CompiledActuators = (Vec<Arc<dyn Actuator>>, Vec<(String, f64)>);

fn actuators(
    b: &Behaviour,
    cx: &mut Context<'_>,
) -> Result<(CompiledActuators, Vec<ActuatorLaw>), SimError> {
    let (mut actuators, mut laws, mut quantities) = (Vec::new(), Vec::new(), Vec::new());
    for (name, spec) in &b.actuators {
        let (a, derived, law) = actuator(cx, &format!("actuators.{name}"), spec)?;
        let stall = if cx.tangent {
            law.stall_grad()
        } else {
            cx.empty.clone()
        };
        let tau = a.joint_torque_n_m(1.0, 0.0);
        quantities.push((name, "stall_torque_n_m", tau, stall));
        quantities.extend(derived.into_iter().map(|(q, v, g)| (name, q, v, g)));
        actuators.push(a);
        laws.push(law);
    }
    let mut given = Vec::with_capacity(quantities.len());
    for (name, quantity, v, g) in quantities {
        let key = format!("{name}.{quantity}");
        cx.values.insert(key.clone(), v);
        if cx.tangent {
            cx.grads.insert(key.clone(), g);
        }
        given.push((key, v));
    }
    Ok(((actuators, given), laws))
}

/// The actuators of `b` as `kept` where it holds (their quantities inserted into the
/// context's values), else compiled ([`actuators`]) and, when `record`, kept with the names
/// they read.
#[allow(clippy::type_complexity)]
fn kept_or_compiled_actuators(
    b: &Behaviour,
    cx: &mut Context<'_>,
    kept: Option<&Reused<CompiledActuators>>,
    record: bool,
) -> Result<
    (
        CompiledActuators,
        Vec<ActuatorLaw>,
        Option<Reused<CompiledActuators>>,
    ),
    SimError,
> {
    if let Some(a) = kept.filter(|a| a.holds(&cx.values)) {
        for (key, v) in &a.value.1 {
            cx.values.insert(key.clone(), *v);
        }
        return Ok((a.value.clone(), Vec::new(), None));
    }
    if record {
        *cx.log.get_mut() = Some(Vec::new());
    }
    let compiled = actuators(b, cx);
    let reads = cx.log.get_mut().take().unwrap_or_default();
    let (a, laws) = compiled?;
    let recorded = record.then(|| Reused {
        value: a.clone(),
        reads,
    });
    Ok((a, laws, recorded))
}

/// What a compilation of a behaviour keeps for the next ones of the same behaviour, robot and
/// start with other parameter values (a sweep's points, a preset's leaps:
/// [`crate::Simulation::rebind`]): its actuators and each phase of each program, with the
/// values of the names each read. A later compilation takes a part as kept where every name
/// it read has the same value, bit for bit, and compiles the rest again: it gives the
/// controller a fresh compilation gives, bit for bit. Filled by the first compilation that
/// is given it ([`compile_bound`]).
#[derive(Default)]
pub struct ReusableParts(OnceLock<Parts>);

struct Parts {
    /// The inputs the parts were compiled from, apart from the parameters.
    behaviour: Arc<Behaviour>,
    model: Arc<Model>,
    q0: Vec<f64>,
    /// The names resolved and the structure checked (no parameter read).
    skeleton: Arc<Skeleton>,
    actuators: Reused<CompiledActuators>,
    named: Reused<Vec<NamedPlan>>,
    /// The free joints' gains `(kp, kd)`.
    free_gains: Reused<(f64, f64)>,
    /// By program, then phase.
    phases: Vec<Vec<Reused<PhasePlan>>>,
}

/// What a behaviour's compilation on a robot resolves and checks without reading a
/// parameter: the names of its actuators, named events and programs, the order the named
/// events are checked in, the program of each joint. Its phases' references to each other
/// were checked for deadlocks ([`check_phase_cycles`]) too.
struct Skeleton {
    actuator_names: Vec<String>,
    named: Vec<String>,
    /// `(joint name, phase names)` of every program.
    programs: Vec<(String, Vec<String>)>,
    program_of_joint: Vec<Option<usize>>,
    /// The joint of each program.
    program_joints: Vec<usize>,
    /// The named events in the order they are checked, and each one's place in that order.
    order: Vec<usize>,
    remap: Vec<usize>,
    /// Joints without a program.
    idle_joints: Vec<usize>,
}

impl Skeleton {
    /// The skeleton of `b` on `model` (errors name the field).
    fn of(b: &Behaviour, model: &Model) -> Result<Self, SimError> {
        let named: Vec<String> = b.events.keys().cloned().collect();
        let (programs, program_of_joint) = program_names(b, model)?;
        let order = named_order(b, &named)?;
        // indices in `named` are re-mapped to check order
        let remap = (0..named.len())
            .map(|n| order.iter().position(|&o| o == n).expect("a permutation"))
            .collect();
        let idle_joints = (0..model.n_joints())
            .filter(|&j| program_of_joint[j].is_none())
            .collect();
        let mut program_joints = vec![0; programs.len()];
        for (j, p) in program_of_joint.iter().enumerate() {
            if let Some(p) = *p {
                program_joints[p] = j;
            }
        }
        Ok(Skeleton {
            actuator_names: b.actuators.keys().cloned().collect(),
            named,
            programs,
            program_of_joint,
            program_joints,
            order,
            remap,
            idle_joints,
        })
    }
}

impl Parts {
    /// Whether the parts were compiled from `b` on `model` from `q0`.
    fn compiled_from(&self, b: &Arc<Behaviour>, model: &Arc<Model>, q0: &[f64]) -> bool {
        Arc::ptr_eq(&self.behaviour, b)
            && Arc::ptr_eq(&self.model, model)
            && self.q0.len() == q0.len()
            && self
                .q0
                .iter()
                .zip(q0)
                .all(|(a, b)| a.to_bits() == b.to_bits())
    }
}

/// A compiled part and the names it read with their values' bits.
struct Reused<T> {
    value: T,
    reads: Vec<(String, u64)>,
}

impl<T> Reused<T> {
    /// Whether every name the part read has the same value in `values`.
    fn holds(&self, values: &BTreeMap<String, f64>) -> bool {
        self.reads
            .iter()
            .all(|(n, bits)| values.get(n).is_some_and(|v| v.to_bits() == *bits))
    }
}

/// Checks `b` against `model` and compiles it into the interpreter, starting from
/// `(q0, qd0)` (the joints' start angles are the expression variable `q0`); phases that
/// start at known times are planned up to `horizon_s` (the run's final time).
pub fn compile(
    b: &Behaviour,
    model: &Model,
    q0: &[f64],
    qd0: &[f64],
    horizon_s: f64,
) -> Result<BehaviourController, SimError> {
    compile_shared(b, &Arc::new(model.clone()), q0, qd0, horizon_s)
}

/// [`compile`] for a model already shared. The plan's parameter tangent (`tangent.rs`) is
/// not computed here but on first use (by the sensitivities): the behaviour is compiled
/// again then, with gradients, from a copy of its inputs — a run that is not
/// differentiated does not pay for it.
pub fn compile_shared(
    b: &Behaviour,
    model: &Arc<Model>,
    q0: &[f64],
    qd0: &[f64],
    horizon_s: f64,
) -> Result<BehaviourController, SimError> {
    // one copy: the parameters apart, the rest shared by the tangent's source
    let mut b = b.clone();
    let p = Arc::new(std::mem::take(&mut b.parameters));
    let formulas = Arc::new(ParsedFormulas::default());
    compile_bound(
        &Arc::new(b),
        &p,
        (&formulas, None),
        model,
        q0,
        qd0,
        horizon_s,
    )
}

/// [`compile_shared`] of `b` with `parameters` in place of its own (`b.parameters` is not
/// read: the values a sweep's point or a preset binds), both shared rather than copied, its
/// formulas parsed once in `formulas` and, given `parts`, its parts that do not depend on the
/// parameters that changed taken from there (both kept by the caller for every compilation of
/// `b`; the first compilation given `parts` fills it):
/// the controller [`compile_shared`] gives for `b` with those parameters set, bit for bit.
/// What a [`crate::Simulation::rebind`] compiles.
pub fn compile_bound(
    b: &Arc<Behaviour>,
    parameters: &Arc<Parameters>,
    (formulas, parts): (&Arc<ParsedFormulas>, Option<&ReusableParts>),
    model: &Arc<Model>,
    q0: &[f64],
    qd0: &[f64],
    horizon_s: f64,
) -> Result<BehaviourController, SimError> {
    let (b2, p2, m2) = (Arc::clone(b), Arc::clone(parameters), Arc::clone(model));
    let f2 = Arc::clone(formulas);
    let (q, qd) = (q0.to_vec(), qd0.to_vec());
    let make = move || {
        let c = compile_with(&b2, (&p2, &f2), (&m2, (&q, &qd)), horizon_s, (true, None))
            .expect("the same behaviour compiled before");
        c.take_tangent()
    };
    let c = compile_with(
        b,
        (parameters, formulas),
        (model, (q0, qd0)),
        horizon_s,
        (false, parts),
    )?;
    c.set_tangent_source(Box::new(make));
    Ok(c)
}

/// [`compile`] with the parameters `p`, the plan's tangent computed when `tangent`; without
/// it, the parts of `parts` taken where they hold (recorded there by the first compilation
/// given it).
fn compile_with(
    b: &Arc<Behaviour>,
    (p, formulas): (&Parameters, &ParsedFormulas),
    (model, (q0, qd0)): (&Arc<Model>, (&[f64], &[f64])),
    horizon_s: f64,
    (tangent, parts): (bool, Option<&ReusableParts>),
) -> Result<BehaviourController, SimError> {
    let parts = parts.filter(|_| !tangent);
    let kept = parts
        .and_then(|p| p.0.get())
        .filter(|k| k.compiled_from(b, model, q0));
    let record = parts.is_some_and(|p| p.0.get().is_none());
    let nq = model.nq();
    for (field, v) in [("q0", q0), ("qd0", qd0)] {
        if v.len() != nq {
            return Err(invalid(
                field,
                format!("expected {nq} coordinates, got {}", v.len()),
            ));
        }
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(invalid(format!("{field}[{i}]"), "must be finite"));
        }
    }
    let values = parameters(p, formulas)?;
    let grads = if tangent {
        parameter_grads(p, &values, formulas)
    } else {
        BTreeMap::new()
    };
    let mut cx = Context {
        model,
        values,
        grads,
        n: p.len(),
        tangent,
        empty: Arc::new([]),
        formulas,
        log: RefCell::new(None),
    };
    let ((actuators, _), laws, recorded_actuators) =
        kept_or_compiled_actuators(b, &mut cx, kept.map(|k| &k.actuators), record)?;
    let skeleton = match kept {
        Some(k) => Arc::clone(&k.skeleton),
        None => Arc::new(Skeleton::of(b, model)?),
    };
    let c = Compiler {
        cx,
        named: &skeleton.named,
        programs: &skeleton.programs,
    };
    let named_plans = kept_or_compiled(kept.map(|k| &k.named), &c.cx, record, || {
        let sk = &*skeleton;
        let mut plans = Vec::with_capacity(sk.order.len());
        for &n in &sk.order {
            let mut plan = c.named_event(&sk.named[n], &b.events[&sk.named[n]])?;
            plan.after = plan.after.map(|a| sk.remap[a]);
            plans.push(plan);
        }
        Ok(plans)
    })?;
    let free = &b.free_joints;
    let free_gains = kept_or_compiled(kept.map(|k| &k.free_gains), &c.cx, record, || {
        let kp =
            c.cx.number("free_joints.kp_per_s2", &free.kp_per_s2, None)?;
        let kp = non_negative("free_joints.kp_per_s2", kp)?;
        let kd = c.cx.number("free_joints.kd_per_s", &free.kd_per_s, None)?;
        Ok((kp, non_negative("free_joints.kd_per_s", kd)?))
    })?;
    let mut programs = Vec::with_capacity(b.joints.len());
    let mut phase_tangents = Vec::new();
    let mut recorded_phases = Vec::new();
    for (i, prog) in b.joints.iter().enumerate() {
        let reuse = kept.and_then(|k| k.phases.get(i)).map(Vec::as_slice);
        let names = (&skeleton.remap[..], &skeleton.actuator_names[..]);
        let ij = (i, skeleton.program_joints[i]);
        let (program, tangents, recorded) = c.program(ij, prog, q0, names, (reuse, record))?;
        programs.push(program);
        recorded_phases.push(recorded);
        if tangent {
            phase_tangents.push(tangents);
        }
    }
    if kept.is_none() {
        // structure only: what the kept parts were compiled from passed it
        check_phase_cycles(&programs, &skeleton.programs)?;
    }
    if let (Some(parts), Some(actuators)) = (parts.filter(|_| record), recorded_actuators) {
        // a concurrent first compilation may have kept its own: the same parts
        let _ = parts.0.set(Parts {
            behaviour: Arc::clone(b),
            model: Arc::clone(model),
            q0: q0.to_vec(),
            skeleton: Arc::clone(&skeleton),
            actuators,
            named: Reused {
                value: named_plans.value.clone(),
                reads: named_plans.reads,
            },
            free_gains: Reused {
                value: free_gains.value,
                reads: free_gains.reads,
            },
            phases: recorded_phases,
        });
    }
    let tangent = tangent.then(|| PlanTangent {
        names: p.keys().cloned().collect(),
        kp_free: c.cx.grad(&free.kp_per_s2, None),
        kd_free: c.cx.grad(&free.kd_per_s, None),
        values: Arc::new(c.cx.grads),
        phases: phase_tangents,
        actuators: laws,
    });
    let (kp_free, kd_free) = free_gains.value;
    let plan = Plan {
        tangent: tangent.map_or_else(OnceLock::new, OnceLock::from),
        tangent_source: OnceLock::new(),
        idle_joints: skeleton.idle_joints.clone(),
        programs,
        actuators,
        named: named_plans.value,
        program_of_joint: skeleton.program_of_joint.clone(),
        kp_free,
        kd_free,
        horizon_s: if horizon_s.is_nan() {
            f64::INFINITY
        } else {
            horizon_s
        },
    };
    BehaviourController::new(plan, q0, qd0).map_err(|p| {
        invalid(
            format!("joints[{p}]"),
            "plans more than 10000 phases ahead: a repeating program needs an event or a \
             positive delay in its cycle",
        )
    })
}

/// `kept` where it holds (every name it read has the same value in `cx`), else `part()`
/// compiled, with the names it read when `record` (for [`ReusableParts`]).
fn kept_or_compiled<T: Clone>(
    kept: Option<&Reused<T>>,
    cx: &Context<'_>,
    record: bool,
    part: impl FnOnce() -> Result<T, SimError>,
) -> Result<Reused<T>, SimError> {
    match kept.filter(|k| k.holds(&cx.values)) {
        Some(k) => Ok(Reused {
            value: k.value.clone(),
            reads: Vec::new(),
        }),
        None => cx.recording(record, part),
    }
}
