//! `Robot`: any planar robot (from a description) or the RHex instance (from Table 4.2
//! parameters), with contact modes given as RHex labels (`"0101"`) or as contact names
//! (`"front_leg,rear_body"`, `"front_leg:slide"`).
use crate::{guard, to_py_err};
use nalgebra::{DMatrix, DVector};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use rhex_model::quasistatic_map::{contact_mode_map, quasi_static_pose, QuasiStaticPose};
use rhex_model::{Rhex, RhexParams};
use selfmanip_core::contact::contact_geometry;
use selfmanip_core::inertia::potential_energy;
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::quasistatic::quasi_static;
use selfmanip_core::{
    forward_dynamics, kinetic_energy, plastic_impact, ContactMode, Data, FlatGround, Model,
    RobotDescription, RowDirection,
};

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<Robot>()?;
    m.add_function(wrap_pyfunction!(rhex_default_params_json, m)?)?;
    m.add_function(wrap_pyfunction!(ground_reaction_complex_json, m)?)?;
    Ok(())
}

/// The ground reaction complex of chapter 3 (cells, Hasse edges, allowable edges with their
/// categories, leap words, strategies) as JSON.
#[pyfunction]
fn ground_reaction_complex_json() -> String {
    rhex_model::grc::grc_json().to_string()
}

/// The shipped Table 4.2 parameters as JSON (the defaults of `selfmanip.rhex.Model`).
#[pyfunction]
fn rhex_default_params_json() -> PyResult<String> {
    serde_json::to_string(&RhexParams::default()).map_err(to_py_err)
}

fn vec1<'py>(py: Python<'py>, v: &DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    v.as_slice().to_vec().into_pyarray(py)
}

fn mat<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// Embeds a matrix over the `dynamic` coordinates into a `rows × nq` (or `nq × nq`) one.
fn embed(
    m: &DMatrix<f64>,
    row_map: &[usize],
    col_map: &[usize],
    nrows: usize,
    ncols: usize,
) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(nrows, ncols);
    for (i, &r) in row_map.iter().enumerate() {
        for (j, &c) in col_map.iter().enumerate() {
            out[(r, c)] = m[(i, j)];
        }
    }
    out
}

/// A planar robot with its contact-mode vocabulary.
#[pyclass(module = "selfmanip._native", frozen)]
pub struct Robot {
    model: Model,
    rhex: Option<Rhex>,
}

impl Robot {
    fn mode(&self, spec: &str) -> PyResult<ContactMode> {
        match &self.rhex {
            Some(r) => r.mode(spec).map_err(to_py_err),
            None => ContactMode::parse_names(&self.model, spec).map_err(to_py_err),
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
            crate::SelfmanipError::new_err("this call needs an RHex model (selfmanip.rhex.Model)")
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

    fn pose_dict<'py>(py: Python<'py>, p: &QuasiStaticPose) -> PyResult<Bound<'py, PyDict>> {
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
    /// The RHex model from Table 4.2 parameters given as JSON (missing keys keep defaults).
    #[staticmethod]
    fn rhex_from_params_json(params_json: &str) -> PyResult<Self> {
        guard(|| {
            let mut base = serde_json::to_value(RhexParams::default()).map_err(to_py_err)?;
            let user: serde_json::Value = serde_json::from_str(params_json).map_err(to_py_err)?;
            let (Some(b), Some(u)) = (base.as_object_mut(), user.as_object()) else {
                return Err(crate::SelfmanipError::new_err("params must be a mapping"));
            };
            for (k, v) in u {
                if !b.contains_key(k) {
                    let known: Vec<&String> = b.keys().collect();
                    return Err(crate::SelfmanipError::new_err(format!(
                        "RHex parameter `{k}`: unknown key (known: {known:?})"
                    )));
                }
                b.insert(k.clone(), v.clone());
            }
            let params: RhexParams = serde_json::from_value(base.clone()).map_err(|e| {
                // name the offending key: the first one that fails on its own
                let defaults = serde_json::to_value(RhexParams::default()).unwrap_or_default();
                let culprit = u.iter().find_map(|(k, v)| {
                    let mut one = defaults.clone();
                    one[k.as_str()] = v.clone();
                    serde_json::from_value::<RhexParams>(one)
                        .err()
                        .map(|e| (k.clone(), e))
                });
                match culprit {
                    Some((k, e1)) => {
                        crate::SelfmanipError::new_err(format!("RHex parameter `{k}`: {e1}"))
                    }
                    None => crate::SelfmanipError::new_err(format!("RHex parameters: {e}")),
                }
            })?;
            let rhex = Rhex::new(params).map_err(to_py_err)?;
            Ok(Robot {
                model: rhex.model.clone(),
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
                    return Err(crate::SelfmanipError::new_err(format!(
                        "format `{other}`: expected \"toml\" or \"json\""
                    )))
                }
            }
            .map_err(to_py_err)?;
            Ok(Robot {
                model: d.build().map_err(to_py_err)?,
                rhex: None,
            })
        })
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
        let mut v: Vec<String> = self
            .model
            .joints
            .iter()
            .map(|j| format!("{}_{}", self.model.legs[j.leg].name, j.index_in_leg))
            .collect();
        v.extend(["x", "z", "phi"].map(String::from));
        v
    }

    #[getter]
    fn is_rhex(&self) -> bool {
        self.rhex.is_some()
    }

    /// The RHex parameters as JSON (RHex models only).
    fn params_json(&self) -> PyResult<String> {
        serde_json::to_string(&self.rhex()?.params).map_err(to_py_err)
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
    ) -> PyResult<Bound<'py, PyDict>> {
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
            .map_err(to_py_err)?;
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
    fn kkt<'py>(&self, py: Python<'py>, mode: &str, q: Vec<f64>) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let mode = self.mode(mode)?;
            let nq = self.model.nq();
            let mut data = Data::new(&self.model);
            data.prepare(&self.model, &FlatGround, mode, &q, &vec![0.0; nq])
                .map_err(to_py_err)?;
            let b = data.kkt.blocks();
            let c = data.constraints.n_rows();
            let rows: Vec<usize> = (0..c).collect();
            let dc = data.dynamic_coords.clone();
            let d = PyDict::new(py);
            d.set_item("m_dagger", mat(py, &embed(&b.m_dagger, &dc, &dc, nq, nq)))?;
            d.set_item("a_dagger", mat(py, &embed(&b.a_dagger, &rows, &dc, c, nq)))?;
            d.set_item("Lambda", mat(py, &b.lambda))?;
            d.set_item("A", mat(py, &data.constraints.a))?;
            d.set_item("M", mat(py, &data.m_bar))?;
            d.set_item("rows", self.rows(py, &data)?)?;
            d.set_item("dynamic_coords", dc)?;
            d.set_item("constraint_condition", data.kkt.info.constraint_condition)?;
            d.set_item(
                "reduced_mass_condition",
                data.kkt.info.reduced_mass_condition,
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
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let mode = self.mode(mode)?;
            let mut data = Data::new(&self.model);
            let imp = plastic_impact(&self.model, &mut data, &FlatGround, mode, &q, &qd_minus)
                .map_err(to_py_err)?;
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
                .map_err(to_py_err)?;
            Ok((
                kinetic_energy(&data, &qd),
                potential_energy(&self.model, &data.kin),
            ))
        })
    }

    /// Height of every contact site above flat ground, `{name: gap_m}` (negative = penetration).
    fn contact_gaps(&self, q: Vec<f64>) -> PyResult<Vec<(String, f64)>> {
        guard(|| {
            let nq = self.model.nq();
            if q.len() != nq {
                return Err(crate::SelfmanipError::new_err(format!(
                    "`q` has length {}, expected {nq}",
                    q.len()
                )));
            }
            if let Some(i) = q.iter().position(|v| !v.is_finite()) {
                return Err(crate::SelfmanipError::new_err(format!(
                    "`q` has a non-finite entry at index {i}"
                )));
            }
            let mut kin = Kinematics::default();
            kin.compute(&self.model, &q, &vec![0.0; nq]);
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

    /// Quasi-static forces (4.21)–(4.23): internal force basis ker G_s, the particular
    /// solution under torque constraints `t` (rows of tᵀτ = 0, given as a list of n-vectors).
    #[pyo3(signature = (mode, q, torque_constraints=Vec::new()))]
    fn quasi_static<'py>(
        &self,
        py: Python<'py>,
        mode: &str,
        q: Vec<f64>,
        torque_constraints: Vec<Vec<f64>>,
    ) -> PyResult<Bound<'py, PyDict>> {
        guard(|| {
            let mode = self.mode(mode)?;
            let n = self.model.n_joints();
            for (i, c) in torque_constraints.iter().enumerate() {
                if c.len() != n {
                    return Err(crate::SelfmanipError::new_err(format!(
                        "`torque_constraints[{i}]` has length {}, expected {n}",
                        c.len()
                    )));
                }
            }
            let t = DMatrix::from_fn(n, torque_constraints.len(), |i, j| torque_constraints[j][i]);
            let mut data = Data::new(&self.model);
            let qs = quasi_static(&self.model, &mut data, &FlatGround, mode, &q, &t)
                .map_err(to_py_err)?;
            let d = PyDict::new(py);
            d.set_item("G_s", mat(py, &qs.g_s))?;
            d.set_item("J_h", mat(py, &qs.j_h))?;
            d.set_item("internal_basis", mat(py, &qs.internal_basis))?;
            d.set_item("internal_torques", mat(py, &qs.internal_torques))?;
            d.set_item("f_particular", vec1(py, &qs.f_particular))?;
            d.set_item("lam_particular", vec1(py, &qs.lambda_particular))?;
            d.set_item("tau_particular", vec1(py, &qs.tau_particular))?;
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
                return Err(crate::SelfmanipError::new_err(
                    "`theta1`/`theta2` must be finite",
                ));
            }
            quasi_static_pose(self.rhex()?, theta1, theta2)
                .map(|p| Self::pose_dict(py, &p))
                .transpose()
        })
    }

    /// RHex: Fig. 4.3/4.6 as data on an `n × n` grid over the joint torus.
    fn contact_mode_map<'py>(&self, py: Python<'py>, n: usize) -> PyResult<Bound<'py, PyList>> {
        guard(|| {
            if n == 0 || n > 4096 {
                return Err(crate::SelfmanipError::new_err("`n` must be in 1..=4096"));
            }
            let poses = contact_mode_map(self.rhex()?, n);
            let items = poses
                .iter()
                .map(|p| Self::pose_dict(py, p))
                .collect::<PyResult<Vec<_>>>()?;
            PyList::new(py, items)
        })
    }
}
