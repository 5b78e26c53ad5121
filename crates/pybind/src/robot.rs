//! `Robot`: any planar robot (from a description) or the RHex instance (from Table 4.2
//! parameters), with contact modes given as RHex labels (`"0101"`) or as contact names
//! (`"front_leg,rear_body"`, `"front_leg:slide"`).
use crate::convert::{column, to_map, to_py, AnyOut, DictOut};
use crate::errors::{self, guard, invalid, Source};
use nalgebra::{DMatrix, DVector, Vector2};
use numpy::ndarray::{Array2, Array3};
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use rhex_model::quasistatic_map::{contact_mode_map, quasi_static_pose, QuasiStaticPose};
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::dynamics::potential_energy;
use selfmanip_core::kinematics::{Kinematics, Part};
use selfmanip_core::quasistatic::quasi_static;
use selfmanip_core::{
    forward_dynamics, kinetic_energy, plastic_impact, ContactMode, CoreError, Data, FlatGround,
    Model, RobotDescription, RowDirection,
};

/// Refuses a result with a non-finite entry: finite but extreme inputs (a mass of 1e308) can
/// overflow inside the engine, and a NaN must not be handed back as if it were an answer.
fn finite_result(field: &'static str, v: &[f64]) -> PyResult<()> {
    match v.iter().position(|x| !x.is_finite()) {
        Some(i) => Err(errors::engine(errors::non_finite_state(field, i, v[i]))),
        None => Ok(()),
    }
}

/// A core error about the caller's own inputs.
fn core_err(e: CoreError) -> PyErr {
    errors::core(e, Source::Caller)
}

/// An RHex error about the caller's own inputs.
fn rhex_err(e: rhex_model::RhexError) -> PyErr {
    errors::rhex(e, Source::Caller)
}

/// Checks a state vector the caller passed: its length and finite entries (as the core does
/// in its own entry points).
fn check_vector(field: &'static str, v: &[f64], expected: usize) -> PyResult<()> {
    if v.len() != expected {
        return Err(core_err(CoreError::WrongLength {
            field,
            expected,
            actual: v.len(),
        }));
    }
    match v.iter().position(|x| !x.is_finite()) {
        Some(index) => Err(core_err(CoreError::NonFinite {
            field,
            index,
            value: v[index],
        })),
        None => Ok(()),
    }
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Robot>()?;
    add_functions! { m, rhex_default_params, ground_reaction_complex }
    Ok(())
}

/// The ground reaction complex of chapter 3 (cells, Hasse edges, allowable edges with their
/// categories, leap words, strategies) as a dict.
#[pyfunction]
fn ground_reaction_complex(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    crate::convert::from_value(py, &rhex_model::grc::grc_json())
}

/// The shipped Table 4.2 parameters (the defaults of `selfmanip.rhex.Model`) as a dict.
#[pyfunction]
fn rhex_default_params(py: Python<'_>) -> PyResult<Bound<'_, PyAny>> {
    to_py(py, &RhexParams::default())
}

fn vec1<'py>(py: Python<'py>, v: &DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    v.as_slice().to_vec().into_pyarray(py)
}

fn mat<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A planar robot with its contact-mode vocabulary.
#[pyclass(module = "selfmanip._native", frozen)]
pub struct Robot {
    model: Model,
    rhex: Option<Rhex>,
    /// The description the model was built from (for `selfmanip.simulate`).
    description: RobotDescription,
}

impl Robot {
    /// The model (for the other bindings).
    pub(crate) fn model(&self) -> &Model {
        &self.model
    }

    /// The description the model was built from (for the simulation bindings).
    pub(crate) fn description(&self) -> &RobotDescription {
        &self.description
    }

    fn mode(&self, spec: &str) -> PyResult<ContactMode> {
        match &self.rhex {
            Some(r) => r.mode(spec).map_err(rhex_err),
            None => ContactMode::parse_names(&self.model, spec).map_err(core_err),
        }
    }

    fn mode_label(&self, mode: ContactMode) -> String {
        match &self.rhex {
            Some(r) => r.label(mode),
            None => mode
                .active()
                .map(|k| self.model.contacts[k].name.clone())
                .collect::<Vec<_>>()
                .join(","),
        }
    }

    fn rhex(&self) -> PyResult<&Rhex> {
        self.rhex.as_ref().ok_or_else(|| {
            errors::invalid_type(
                "model",
                format!(
                    "this call needs the RHex model (selfmanip.rhex.Model), not the robot `{}`",
                    self.model.name
                ),
            )
        })
    }

    /// `[(contact name, "tangential" | "normal"), …]` in the row order of `A` and `λ`.
    fn rows<'py>(&self, py: Python<'py>, data: &Data) -> PyResult<Bound<'py, PyList>> {
        let rows: Vec<(String, &str)> = data
            .constraints
            .rows
            .iter()
            .map(|r| {
                let dir = match r.direction {
                    RowDirection::Tangential => "tangential",
                    RowDirection::Normal => "normal",
                };
                (self.model.contacts[r.contact].name.clone(), dir)
            })
            .collect();
        PyList::new(py, rows)
    }

    /// Forward kinematics at the caller's `(q, qd)` (`qd` zero when not given), checked.
    fn kinematics_at(&self, q: &[f64], qd: Option<&[f64]>) -> PyResult<Kinematics> {
        let nq = self.model.nq();
        check_vector("q", q, nq)?;
        let zero = vec![0.0; nq];
        let qd = match qd {
            Some(v) => {
                check_vector("qd", v, nq)?;
                v
            }
            None => &zero,
        };
        let mut kin = Kinematics::default();
        kin.compute(&self.model, q, qd);
        if kin.check_finite().is_err() {
            // finite inputs near the largest f64 overflow: the poses are `q`'s, the rest `qd`'s
            let poses = [kin.body_pos.x, kin.body_pos.y, kin.phi]
                .into_iter()
                .chain(kin.origin.iter().flat_map(|v| [v.x, v.y]))
                .chain(kin.beta.iter().copied());
            let field = if poses.into_iter().all(f64::is_finite) {
                "qd"
            } else {
                "q"
            };
            return Err(invalid(
                field,
                format!("`{field}`: too large: the parts' poses and velocities overflow at it"),
            ));
        }
        Ok(kin)
    }

    /// The part `None` (body) or `Some(j)` (the link of joint `j`), checked.
    fn part(&self, part: Option<i64>) -> PyResult<Part> {
        match part {
            None => Ok(Part::Body),
            Some(j) if (0..self.model.n_joints() as i64).contains(&j) => Ok(Part::Link(j as usize)),
            Some(j) => Err(invalid(
                "part",
                format!(
                    "`part`: joint index {j} is not in 0..{}",
                    self.model.n_joints()
                ),
            )),
        }
    }

    fn pose_dict<'py>(py: Python<'py>, p: &QuasiStaticPose) -> DictOut<'py> {
        let d = PyDict::new(py);
        d.set_item("theta1", p.theta1)?;
        d.set_item("theta2", p.theta2)?;
        d.set_item("phi", p.phi)?;
        d.set_item("front", p.front.letter().to_string())?;
        d.set_item("rear", p.rear.letter().to_string())?;
        d.set_item("height_m", p.height_m)?;
        d.set_item("label", p.label.clone())?;
        Ok(d)
    }
}

#[pymethods]
impl Robot {
    /// The RHex model from Table 4.2 parameters given as a dict (missing keys keep the
    /// shipped values).
    #[staticmethod]
    fn rhex_from_params(params: &Bound<'_, PyDict>) -> PyResult<Self> {
        guard(|| {
            let user = to_map(params, "")?;
            let defaults = serde_json::to_value(RhexParams::default())
                .map_err(|e| errors::engine(e.to_string()))?;
            let mut base = defaults.clone();
            let b = base
                .as_object_mut()
                .ok_or_else(|| errors::engine("RHex parameters are not a mapping"))?;
            for (k, v) in &user {
                if !b.contains_key(k) {
                    let known: Vec<&String> = b.keys().collect();
                    return Err(invalid(
                        k,
                        format!("RHex parameter `{k}`: unknown key (known: {known:?})"),
                    ));
                }
                b.insert(k.clone(), v.clone());
            }
            let params: RhexParams = serde_json::from_value(base).map_err(|e| {
                // name the offending key: the first one that fails on its own
                let culprit = user.iter().find_map(|(k, v)| {
                    let mut one = defaults.clone();
                    one[k.as_str()] = v.clone();
                    serde_json::from_value::<RhexParams>(one)
                        .err()
                        .map(|e| (k.clone(), e))
                });
                match culprit {
                    Some((k, e1)) => invalid(&k, format!("RHex parameter `{k}`: {e1}")),
                    None => invalid("params", format!("RHex parameters: {e}")),
                }
            })?;
            let rhex = Rhex::new(params).map_err(rhex_err)?;
            Ok(Robot {
                model: rhex.model.clone(),
                description: rhex.params.description(),
                rhex: Some(rhex),
            })
        })
    }

    /// A robot from a description text (`format` is `"toml"` or `"json"`).
    #[staticmethod]
    fn from_description(text: &str, format: &str) -> PyResult<Self> {
        guard(|| {
            let d = match format {
                "toml" => RobotDescription::from_toml_str(text),
                "json" => RobotDescription::from_json_str(text),
                other => {
                    return Err(invalid(
                        "format",
                        format!("format `{other}`: expected \"toml\" or \"json\""),
                    ))
                }
            }
            .map_err(core_err)?;
            Ok(Robot {
                model: d.build().map_err(core_err)?,
                rhex: None,
                description: d,
            })
        })
    }

    /// A robot from a description given as plain data (the dict form of a TOML/JSON
    /// description; numbers cross exactly, no text is parsed).
    #[staticmethod]
    fn from_description_data(description: &Bound<'_, PyDict>) -> PyResult<Self> {
        guard(|| {
            let value = serde_json::Value::Object(to_map(description, "")?);
            let d: RobotDescription = serde_json::from_value(value).map_err(|e| {
                core_err(CoreError::Parse {
                    format: "python",
                    message: e.to_string(),
                })
            })?;
            Ok(Robot {
                model: d.build().map_err(core_err)?,
                rhex: None,
                description: d,
            })
        })
    }

    /// `pickle` and `copy`: the robot is rebuilt from what it was made of (the RHex
    /// parameters, or the description as plain data), so that the copy is the same model.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let this = slf.get();
        let cls = slf.get_type();
        let (ctor, data) = match &this.rhex {
            Some(r) => ("rhex_from_params", to_py(py, &r.params)?),
            None => ("from_description_data", to_py(py, &this.description)?),
        };
        Ok((cls.getattr(ctor)?, PyTuple::new(py, [data])?))
    }

    /// The description as plain data (the dict form of the TOML/JSON file).
    fn description_data<'py>(&self, py: Python<'py>) -> AnyOut<'py> {
        to_py(py, &self.description)
    }

    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }

    #[getter]
    fn nq(&self) -> usize {
        self.model.nq()
    }

    #[getter]
    fn n_joints(&self) -> usize {
        self.model.n_joints()
    }

    #[getter]
    fn contact_names(&self) -> Vec<String> {
        self.model.contacts.iter().map(|c| c.name.clone()).collect()
    }

    /// `q` names: joint names `<leg>_<i>`, then `x`, `z`, `phi`.
    #[getter]
    fn coordinate_names(&self) -> Vec<String> {
        // the one spelling of every output (docs/conventions.md)
        selfmanip_sim::trajectory::q_names(&self.model)
    }

    #[getter]
    fn is_rhex(&self) -> bool {
        self.rhex.is_some()
    }

    /// The RHex parameters as a dict (RHex models only).
    fn params<'py>(&self, py: Python<'py>) -> AnyOut<'py> {
        to_py(py, &self.rhex()?.params)
    }

    /// The generic robot description as TOML (for RHex: the one built from the parameters).
    fn description_toml(&self) -> PyResult<String> {
        Ok(match &self.rhex {
            Some(r) => r.params.description().to_toml_string(),
            None => format!(
                "# {}: loaded from a description; see the source file\n",
                self.model.name
            ),
        })
    }

    /// Every `0`/`1` contact label (RHex) or `None`.
    fn labels(&self) -> Option<Vec<String>> {
        self.rhex.as_ref().map(|r| r.all_labels())
    }

    /// Normalizes a mode spec and echoes it (validates labels and names).
    fn mode_spec(&self, mode: &str) -> PyResult<String> {
        Ok(self.mode_label(self.mode(mode)?))
    }

    /// Thesis (5.3)–(5.4) in `mode` at `(q, qd)` under joint torques `tau`.
    #[pyo3(signature = (mode, q, qd, tau, free_joint_qdd=None))]
    fn dynamics<'py>(
        &self,
        py: Python<'py>,
        mode: &str,
        q: Vec<f64>,
        qd: Vec<f64>,
        tau: Vec<f64>,
        free_joint_qdd: Option<Vec<f64>>,
    ) -> DictOut<'py> {
        guard(|| {
            let mode = self.mode(mode)?;
            let mut data = Data::new(&self.model);
            forward_dynamics(
                &self.model,
                &mut data,
                &FlatGround,
                mode,
                &q,
                &qd,
                &tau,
                free_joint_qdd.as_deref(),
            )
            .map_err(core_err)?;
            finite_result("qdd", data.qdd.as_slice())?;
            finite_result("lam", data.lambda.as_slice())?;
            let d = PyDict::new(py);
            d.set_item("qdd", vec1(py, &data.qdd))?;
            d.set_item("lam", vec1(py, &data.lambda))?;
            d.set_item("rows", self.rows(py, &data)?)?;
            d.set_item("free_joints", data.free_joints.clone())?;
            d.set_item("mode", self.mode_label(mode))?;
            Ok(d)
        })
    }

    /// The KKT blocks M†, A†, Λ of (5.2) and the constraint matrix A, embedded in full
    /// coordinates (rows/columns of free massless joints are zero).
    fn kkt<'py>(&self, py: Python<'py>, mode: &str, q: Vec<f64>) -> DictOut<'py> {
        guard(|| {
            let mode = self.mode(mode)?;
            let nq = self.model.nq();
            let mut data = Data::new(&self.model);
            data.prepare(&self.model, &FlatGround, mode, &q, &vec![0.0; nq])
                .map_err(core_err)?;
            let dc = data.dynamic_coords.clone();
            let b = data.kkt.blocks().embedded(&dc, nq);
            let d = PyDict::new(py);
            d.set_item("m_dagger", mat(py, &b.m_dagger))?;
            d.set_item("a_dagger", mat(py, &b.a_dagger))?;
            d.set_item("Lambda", mat(py, &b.lambda))?;
            d.set_item("A", mat(py, &data.constraints.a))?;
            d.set_item("M", mat(py, &data.m_bar))?;
            d.set_item("rows", self.rows(py, &data)?)?;
            d.set_item("dynamic_coords", dc)?;
            d.set_item("constraint_condition", data.kkt.info().constraint_condition)?;
            d.set_item(
                "reduced_mass_condition",
                data.kkt.info().reduced_mass_condition,
            )?;
            Ok(d)
        })
    }

    /// Plastic impact (5.10)/(5.52) into `mode` at `q` with incoming velocity `qd_minus`.
    fn impact<'py>(
        &self,
        py: Python<'py>,
        mode: &str,
        q: Vec<f64>,
        qd_minus: Vec<f64>,
    ) -> DictOut<'py> {
        guard(|| {
            let mode = self.mode(mode)?;
            let mut data = Data::new(&self.model);
            let imp = plastic_impact(&self.model, &mut data, &FlatGround, mode, &q, &qd_minus)
                .map_err(core_err)?;
            finite_result("qd_plus", imp.qd_plus.as_slice())?;
            finite_result("impulse", imp.impulse.as_slice())?;
            let d = PyDict::new(py);
            d.set_item("qd_plus", vec1(py, &imp.qd_plus))?;
            d.set_item("impulse", vec1(py, &imp.impulse))?;
            d.set_item("rows", self.rows(py, &data)?)?;
            Ok(d)
        })
    }

    /// Kinetic (4.24) and potential energy at `(q, qd)` (J).
    fn energy(&self, q: Vec<f64>, qd: Vec<f64>) -> PyResult<(f64, f64)> {
        guard(|| {
            let mut data = Data::new(&self.model);
            // flight: every configuration is admissible; only M̄ and the poses are needed
            data.prepare(&self.model, &FlatGround, ContactMode::FLIGHT, &q, &qd)
                .or_else(|e| match e {
                    selfmanip_core::CoreError::SingularKkt { .. } => Ok(()),
                    e => Err(e),
                })
                .map_err(core_err)?;
            let energy = (
                kinetic_energy(&data, &qd),
                potential_energy(&self.model, &data.kin, &q),
            );
            finite_result("energy", &[energy.0, energy.1])?;
            Ok(energy)
        })
    }

    /// Height of every contact site above flat ground, `{name: gap_m}` (negative = penetration).
    fn contact_gaps(&self, q: Vec<f64>) -> PyResult<Vec<(String, f64)>> {
        guard(|| {
            let kin = self.kinematics_at(&q, None)?;
            Ok((0..self.model.n_contacts())
                .map(|k| {
                    (
                        self.model.contacts[k].name.clone(),
                        contact_geometry(&self.model, &kin, &FlatGround, k).gap_m,
                    )
                })
                .collect())
        })
    }

    /// Forward kinematics at `q` (and velocities at `qd` when given): the body's position
    /// and pitch, every joint's world position (the origin of its link), every link's world
    /// angle and tip, in NED world coordinates.
    #[pyo3(signature = (q, qd=None))]
    fn forward_kinematics<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        qd: Option<Vec<f64>>,
    ) -> DictOut<'py> {
        guard(|| {
            let kin = self.kinematics_at(&q, qd.as_deref())?;
            let n = self.model.n_joints();
            let xy = |v: &[Vector2<f64>]| Array2::from_shape_fn((v.len(), 2), |(i, k)| v[i][k]);
            let tips: Vec<Vector2<f64>> = (0..n)
                .map(|j| {
                    kin.point(
                        Part::Link(j),
                        Vector2::new(0.0, self.model.joints[j].length_m),
                    )
                })
                .collect();
            let d = PyDict::new(py);
            d.set_item(
                "body_position_m",
                vec![kin.body_pos.x, kin.body_pos.y].into_pyarray(py),
            )?;
            d.set_item("body_angle_rad", kin.phi)?;
            d.set_item("joint_positions_m", xy(&kin.origin).into_pyarray(py))?;
            d.set_item("link_angles_rad", kin.beta.clone().into_pyarray(py))?;
            d.set_item("link_tips_m", xy(&tips).into_pyarray(py))?;
            if qd.is_some() {
                let tip_vel: Vec<Vector2<f64>> = (0..n)
                    .map(|j| kin.material_velocity(Part::Link(j), tips[j]))
                    .collect();
                d.set_item(
                    "body_velocity_m_s",
                    vec![kin.body_vel.x, kin.body_vel.y].into_pyarray(py),
                )?;
                d.set_item("body_rate_rad_s", kin.phi_dot)?;
                d.set_item("joint_velocities_m_s", xy(&kin.origin_vel).into_pyarray(py))?;
                d.set_item("link_rates_rad_s", kin.beta_dot.clone().into_pyarray(py))?;
                d.set_item("link_tip_velocities_m_s", xy(&tip_vel).into_pyarray(py))?;
            }
            Ok(d)
        })
    }

    /// The Jacobian of the material point `point_m` (in the frame of `part`: `None` the body,
    /// `j` the link of joint `j`) at `q`: its world position and the 3×nq matrix whose rows
    /// give the point's world velocity `(ẋ, ż)` and the part's angular rate (about +y,
    /// nose-up positive) from `q̇`.
    #[pyo3(signature = (q, part=None, point_m=[0.0, 0.0]))]
    fn jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        part: Option<i64>,
        point_m: [f64; 2],
    ) -> DictOut<'py> {
        guard(|| {
            let kin = self.kinematics_at(&q, None)?;
            check_vector("point_m", &point_m, 2)?;
            let part = self.part(part)?;
            let p = kin.point(part, Vector2::new(point_m[0], point_m[1]));
            let nq = self.model.nq();
            let jp = kin.point_jacobian(&self.model, part, p);
            let mut w = vec![0.0; nq];
            kin.angular_jacobian_row(&self.model, part, &mut w);
            let j = Array2::from_shape_fn((3, nq), |(r, c)| if r < 2 { jp[(r, c)] } else { w[c] });
            let d = PyDict::new(py);
            d.set_item("position_m", vec![p.x, p.y].into_pyarray(py))?;
            d.set_item("angle_rad", kin.part_angle(part))?;
            d.set_item("jacobian", j.into_pyarray(py))?;
            Ok(d)
        })
    }

    /// Every contact site against flat ground at `q`: the contact point (the lowest point of
    /// its shape), its height above the ground, the ground's normal (into the ground), the
    /// 2×nq Jacobian of the material point there and, with `qd`, that point's velocity.
    #[pyo3(signature = (q, qd=None))]
    fn contact_points<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        qd: Option<Vec<f64>>,
    ) -> DictOut<'py> {
        guard(|| {
            let kin = self.kinematics_at(&q, qd.as_deref())?;
            let (nc, nq) = (self.model.n_contacts(), self.model.nq());
            let geom: Vec<_> = (0..nc)
                .map(|k| contact_geometry(&self.model, &kin, &FlatGround, k))
                .collect();
            let jac: Vec<DMatrix<f64>> = geom
                .iter()
                .map(|g| kin.point_jacobian(&self.model, g.part, g.point))
                .collect();
            let d = PyDict::new(py);
            d.set_item(
                "names",
                self.model
                    .contacts
                    .iter()
                    .map(|c| c.name.clone())
                    .collect::<Vec<_>>(),
            )?;
            d.set_item(
                "points_m",
                Array2::from_shape_fn((nc, 2), |(k, i)| geom[k].point[i]).into_pyarray(py),
            )?;
            d.set_item("gaps_m", column(py, &geom, |g| g.gap_m))?;
            d.set_item(
                "normals",
                Array2::from_shape_fn((nc, 2), |(k, i)| geom[k].plane.normal()[i]).into_pyarray(py),
            )?;
            d.set_item(
                "jacobians",
                Array3::from_shape_fn((nc, 2, nq), |(k, r, c)| jac[k][(r, c)]).into_pyarray(py),
            )?;
            if qd.is_some() {
                d.set_item(
                    "velocities_m_s",
                    Array2::from_shape_fn((nc, 2), |(k, i)| {
                        kin.material_velocity(geom[k].part, geom[k].point)[i]
                    })
                    .into_pyarray(py),
                )?;
            }
            Ok(d)
        })
    }

    /// Quasi-static forces (4.21)–(4.23): internal force basis ker G_s, the particular
    /// solution under torque constraints `t` (rows of tᵀτ = 0, given as a list of n-vectors).
    #[pyo3(signature = (mode, q, torque_constraints=Vec::new()))]
    fn quasi_static<'py>(
        &self,
        py: Python<'py>,
        mode: &str,
        q: Vec<f64>,
        torque_constraints: Vec<Vec<f64>>,
    ) -> DictOut<'py> {
        guard(|| {
            let mode = self.mode(mode)?;
            let n = self.model.n_joints();
            for (i, c) in torque_constraints.iter().enumerate() {
                if c.len() != n {
                    return Err(invalid(
                        &format!("torque_constraints[{i}]"),
                        format!(
                            "`torque_constraints[{i}]` has length {}, expected {n}",
                            c.len()
                        ),
                    ));
                }
            }
            let t = DMatrix::from_fn(n, torque_constraints.len(), |i, j| torque_constraints[j][i]);
            let mut data = Data::new(&self.model);
            let qs = quasi_static(&self.model, &mut data, &FlatGround, mode, &q, &t)
                .map_err(core_err)?;
            let d = PyDict::new(py);
            d.set_item("G_s", mat(py, &qs.maps.g_s))?;
            d.set_item("J_h", mat(py, &qs.maps.j_h))?;
            d.set_item("internal_basis", mat(py, &qs.balance.internal_basis))?;
            d.set_item("internal_torques", mat(py, &qs.balance.internal_torques))?;
            d.set_item("f_particular", vec1(py, &qs.balance.f_particular))?;
            d.set_item("lam_particular", vec1(py, &qs.lambda_particular()))?;
            d.set_item("tau_particular", vec1(py, &qs.balance.tau_particular))?;
            d.set_item("gravity_wrench", qs.gravity_wrench.as_slice().to_vec())?;
            Ok(d)
        })
    }

    /// RHex: the quasi-static pose (4.44) at legs `(theta1, theta2)`, or `None`.
    fn quasi_static_pose<'py>(
        &self,
        py: Python<'py>,
        theta1: f64,
        theta2: f64,
    ) -> PyResult<Option<Bound<'py, PyDict>>> {
        guard(|| {
            if !theta1.is_finite() || !theta2.is_finite() {
                let field = if theta1.is_finite() {
                    "theta2"
                } else {
                    "theta1"
                };
                return Err(invalid(field, format!("`{field}` must be finite")));
            }
            quasi_static_pose(self.rhex()?, theta1, theta2)
                .map(|p| Self::pose_dict(py, &p))
                .transpose()
        })
    }

    /// RHex: Fig. 4.3/4.6 as data on an `n × n` grid over the joint torus.
    fn contact_mode_map<'py>(&self, py: Python<'py>, n: i64) -> PyResult<Bound<'py, PyList>> {
        guard(|| {
            // a negative n is out of the engine's range as 0 is
            let n = usize::try_from(n).unwrap_or(0);
            let poses = contact_mode_map(self.rhex()?, n).map_err(rhex_err)?;
            let items = poses
                .iter()
                .map(|p| Self::pose_dict(py, p))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)
        })
    }
}
