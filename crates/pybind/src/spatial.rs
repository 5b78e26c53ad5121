//! `SpatialRobot`: a spatial robot from URDF (`selfmanip_core::spatial`), its kinematics,
//! `M`, `h` and the constrained dynamics and impact of point contacts. Arrays cross as numpy;
//! layouts are Pinocchio's (see `selfmanip_core::spatial`).
//!
//! Contacts are a list of frame names, each with friction (3 rows `[t₁, t₂, n]`) or, with the
//! suffix `:frictionless`, the normal row alone, on flat z-up ground; or a dict
//! `{frame: {"radius_m", "friction", "slide", "normal", "arc"}}` (`SpatialRobot::contact`):
//! sphere feet, arcs, other ground normals and Coulomb sliding.
use crate::convert::{DictOut, MatrixOut, VectorOut};
use crate::errors::{self, guard, invalid, invalid_type, Source};
use nalgebra::{DMatrix, DVector, Vector3};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use selfmanip_core::spatial::kinematics::{
    forward_kinematics, frame_jacobian, frame_placement, ReferenceFrame,
};
use selfmanip_core::spatial::rhex::RhexSixLegs;
use selfmanip_core::spatial::rigid_body::{crba, nonlinear_effects};
use selfmanip_core::spatial::{
    difference, forward_dynamics, forward_dynamics_prescribed, free_rates, from_pinocchio,
    impact_outcomes, impact_with, integrate, kkt_blocks, neutral, quasi_static, to_pinocchio,
    BaseKind, ImpactState, PointContact, Separation, SpatialData, SpatialError, SpatialImpact,
    SpatialModel,
};

/// A spatial error as the Python exception of its kind, naming the field.
fn spatial_err(e: SpatialError) -> PyErr {
    let msg = e.to_string();
    match e {
        SpatialError::UrdfParse { .. } => invalid("urdf", msg),
        SpatialError::InvalidUrdf { field, .. } => invalid(&field, msg),
        SpatialError::NonUnitQuaternion { field, .. } => invalid(field, msg),
        SpatialError::UnknownFrame { .. } => invalid("name", msg),
        SpatialError::InvalidArgument { field, .. } => invalid(&field, msg),
        SpatialError::Core(c) => errors::core(c, Source::Caller),
    }
}

/// Three numbers from `x`, the input that `label` names.
fn three_numbers(x: &Bound<'_, PyAny>, label: &str) -> PyResult<[f64; 3]> {
    let v: Vec<f64> = x
        .extract()
        .map_err(|_| invalid_type(label, "three numbers"))?;
    <[f64; 3]>::try_from(v.as_slice())
        .map_err(|_| invalid(label, format!("{} numbers, expected 3", v.len())))
}

fn vec1<'py>(py: Python<'py>, v: &DVector<f64>) -> Bound<'py, PyArray1<f64>> {
    v.as_slice().to_vec().into_pyarray(py)
}

/// The vector `f` computes, as a numpy array, its error as the Python exception of its kind.
fn vector<'py>(
    py: Python<'py>,
    f: impl FnOnce() -> Result<DVector<f64>, SpatialError>,
) -> VectorOut<'py> {
    guard(|| Ok(vec1(py, &f().map_err(spatial_err)?)))
}

fn mat<'py>(py: Python<'py>, m: &DMatrix<f64>) -> Bound<'py, PyArray2<f64>> {
    Array2::from_shape_fn((m.nrows(), m.ncols()), |(i, j)| m[(i, j)]).into_pyarray(py)
}

/// A contact row's label: `(frame, "t1" | "t2" | "n")`, `(frame, "t" | "n")` on a planar
/// base.
type RowLabel = (String, String);

/// A spatial robot: `SpatialRobot.from_urdf(path, base="free_flyer")`.
#[pyclass(module = "selfmanip._native", frozen)]
pub struct SpatialRobot {
    model: SpatialModel,
    /// What the model was built from (the URDF text, the base, the root link), for `pickle`.
    source: UrdfSource,
}

/// A URDF model's inputs: `SpatialRobot.from_urdf_text(urdf, base, root_link, frames)`
/// rebuilds it.
struct UrdfSource {
    urdf: String,
    base: String,
    root_link: Option<String>,
    frames: Vec<AddedFrame>,
}

/// A frame added to the URDF's (`SpatialModel::add_frame`): `{name: {"parent": frame,
/// "xyz_m": [x, y, z], "rpy_rad": [r, p, y]}}`, the offsets zero where not given.
#[derive(Clone)]
struct AddedFrame {
    name: String,
    parent: String,
    xyz: [f64; 3],
    rpy: [f64; 3],
}

impl AddedFrame {
    /// The frames of `spec`, a dict `{name: {...}}` (`None`: none).
    fn parse(spec: Option<&Bound<'_, PyAny>>) -> PyResult<Vec<Self>> {
        let Some(spec) = spec.filter(|s| !s.is_none()) else {
            return Ok(Vec::new());
        };
        let dict = spec
            .cast::<PyDict>()
            .map_err(|_| invalid_type("frames", "a dict {name: {\"parent\": frame, ...}}"))?;
        let mut frames = Vec::new();
        for (key, value) in dict.iter() {
            let name: String = key
                .extract()
                .map_err(|_| invalid_type("frames", "frame names as keys"))?;
            let field = |k: &str| format!("frames[{name}]{k}");
            let entry = value
                .cast::<PyDict>()
                .map_err(|_| invalid_type(&field(""), "a dict with parent, xyz_m, rpy_rad"))?;
            for k in entry.keys() {
                let k: String = k.extract()?;
                if !["parent", "xyz_m", "rpy_rad"].contains(&k.as_str()) {
                    return Err(invalid(
                        &field(&format!(".{k}")),
                        format!("unknown key `{k}` (parent, xyz_m, rpy_rad)"),
                    ));
                }
            }
            let parent: String = entry
                .get_item("parent")?
                .ok_or_else(|| invalid(&field(".parent"), "missing"))?
                .extract()
                .map_err(|_| invalid_type(&field(".parent"), "a frame name"))?;
            let triple = |k: &str| -> PyResult<[f64; 3]> {
                match entry.get_item(k)? {
                    None => Ok([0.0; 3]),
                    Some(x) => three_numbers(&x, &field(&format!(".{k}"))),
                }
            };
            let (xyz, rpy) = (triple("xyz_m")?, triple("rpy_rad")?);
            frames.push(AddedFrame {
                name,
                parent,
                xyz,
                rpy,
            });
        }
        Ok(frames)
    }

    /// The dict [`Self::parse`] reads back.
    fn to_dict<'py>(frames: &[Self], py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let out = PyDict::new(py);
        for f in frames {
            let entry = PyDict::new(py);
            entry.set_item("parent", &f.parent)?;
            entry.set_item("xyz_m", f.xyz.to_vec())?;
            entry.set_item("rpy_rad", f.rpy.to_vec())?;
            out.set_item(&f.name, entry)?;
        }
        Ok(out)
    }
}

impl UrdfSource {
    fn build(self) -> PyResult<SpatialRobot> {
        let base = BaseKind::from_name(&self.base).map_err(spatial_err)?;
        let mut model = SpatialModel::from_urdf_str(&self.urdf, base, self.root_link.as_deref())
            .map_err(spatial_err)?;
        for f in &self.frames {
            model
                .add_frame(&f.name, &f.parent, f.xyz, f.rpy)
                .map_err(|e| match e {
                    SpatialError::UnknownFrame { ref field, .. } => invalid(field, e.to_string()),
                    other => spatial_err(other),
                })?;
        }
        Ok(SpatialRobot {
            model,
            source: self,
        })
    }
}

impl SpatialRobot {
    /// The contacts of `spec` and their row labels `(frame, "t1"|"t2"|"n")`: a list of frame
    /// names (`"frame"` or `"frame:frictionless"`), or a dict `{frame: {...}}` ([`Self::contact`]).
    fn contacts(&self, spec: &Bound<'_, PyAny>) -> PyResult<(Vec<PointContact>, Vec<RowLabel>)> {
        let mut contacts = Vec::new();
        let mut rows = Vec::new();
        let mut push = |name: &str, c: PointContact| {
            let labels: &[&str] = match c.n_rows() {
                3 => &["t1", "t2", "n"],
                2 => &["t", "n"],
                _ => &["n"],
            };
            rows.extend(labels.iter().map(|l| (name.to_string(), l.to_string())));
            contacts.push(c);
        };
        if let Ok(dict) = spec.cast::<PyDict>() {
            for (key, value) in dict.iter() {
                let name: String = key
                    .extract()
                    .map_err(|_| invalid_type("contacts", "contact keys are frame names"))?;
                let c = self.contact(&name, &value)?;
                push(&name, c);
            }
            return Ok((contacts, rows));
        }
        let names: Vec<String> = spec.extract().map_err(|_| {
            invalid_type("contacts", "a list of frame names or a dict {frame: {...}}")
        })?;
        for spec in &names {
            let (name, friction) = match spec.split_once(':') {
                None => (spec.as_str(), true),
                Some((name, "frictionless")) => (name, false),
                Some((_, other)) => {
                    return Err(invalid(
                        "contacts",
                        format!(
                            "contact `{spec}`: unknown qualifier `{other}` (only `frictionless`)"
                        ),
                    ))
                }
            };
            let c = PointContact::new(&self.model, name, friction).map_err(|e| match e {
                SpatialError::UnknownFrame { .. } => invalid("contacts", e.to_string()),
                other => spatial_err(other),
            })?;
            push(name, c);
        }
        Ok((contacts, rows))
    }

    /// One contact of the dict form, `{"radius_m": r, "friction": mu, "slide": False,
    /// "normal": [0, 0, 1], "arc": {"axis": [..], "zero": [..], "angle_range_rad": [a, b]}}`
    /// (every key optional): a point (`r = 0`) or a sphere foot of radius `r`, or with `arc`
    /// the arc of radius `r`; with `mu > 0` three rows (sticking, and Coulomb's cone of `mu` in
    /// an impact) or, with `slide`, the normal row and Coulomb friction `mu`; `mu = 0`
    /// frictionless. Errors name
    /// `contacts[frame].key`.
    fn contact(&self, name: &str, spec: &Bound<'_, PyAny>) -> PyResult<PointContact> {
        let field = |key: &str| format!("contacts[{name}].{key}");
        let spec = spec.cast::<PyDict>().map_err(|_| {
            invalid_type(&format!("contacts[{name}]"), "a dict of the contact's keys")
        })?;
        for key in spec.keys() {
            let key: String = key.extract()?;
            if !["radius_m", "friction", "slide", "normal", "arc"].contains(&key.as_str()) {
                return Err(invalid(
                    &field(&key),
                    format!("unknown key `{key}` (radius_m, friction, slide, normal, arc)"),
                ));
            }
        }
        let get = |key: &str| spec.get_item(key);
        let number = |key: &str, default: f64| -> PyResult<f64> {
            match get(key)? {
                None => Ok(default),
                Some(x) => x
                    .extract()
                    .map_err(|_| invalid_type(&field(key), "a number")),
            }
        };
        let triple = |d: &Bound<'_, PyDict>, key: &str, label: String| -> PyResult<Vector3<f64>> {
            let x = d.get_item(key)?.ok_or_else(|| invalid(&label, "missing"))?;
            Ok(Vector3::from(three_numbers(&x, &label)?))
        };
        let (radius_m, mu) = (number("radius_m", 0.0)?, number("friction", 0.0)?);
        let slide: bool = match get("slide")? {
            None => false,
            Some(x) => x
                .extract()
                .map_err(|_| invalid_type(&field("slide"), "a bool"))?,
        };
        let normal = match get("normal")? {
            None => Vector3::z(),
            Some(_) => triple(spec, "normal", field("normal"))?,
        };
        let named = |e: SpatialError| match e {
            SpatialError::InvalidArgument { field: f, reason } => invalid(&field(&f), reason),
            SpatialError::UnknownFrame { .. } => invalid("contacts", e.to_string()),
            other => spatial_err(other),
        };
        let c = PointContact::with_normal(&self.model, name, mu > 0.0 && !slide, normal)
            .map_err(named)?;
        let c = match get("arc")? {
            Some(arc) => {
                let arc = arc.cast::<PyDict>().map_err(|_| {
                    invalid_type(&field("arc"), "a dict with axis, zero, angle_range_rad")
                })?;
                let sub = |k: &str| format!("contacts[{name}].arc.{k}");
                let range: Vec<f64> = arc
                    .get_item("angle_range_rad")?
                    .ok_or_else(|| invalid(&sub("angle_range_rad"), "missing"))?
                    .extract()
                    .map_err(|_| invalid_type(&sub("angle_range_rad"), "two numbers"))?;
                if range.len() != 2 {
                    return Err(invalid(&sub("angle_range_rad"), "two numbers [from, to]"));
                }
                let (axis, zero) = (
                    triple(arc, "axis", sub("axis"))?,
                    triple(arc, "zero", sub("zero"))?,
                );
                c.on_arc(radius_m, axis, zero, (range[0], range[1]))
                    .map_err(|e| match e {
                        SpatialError::InvalidArgument { field: f, reason } if f != "radius_m" => {
                            invalid(&sub(&f), reason)
                        }
                        other => named(other),
                    })?
            }
            None if radius_m != 0.0 => c.on_sphere(radius_m).map_err(named)?,
            None => c,
        };
        if slide {
            c.sliding(mu).map_err(named)
        } else if !(mu >= 0.0 && mu.is_finite()) {
            Err(invalid(
                &field("friction"),
                format!("must be finite and non-negative, got {mu}"),
            ))
        } else if mu > 0.0 {
            c.with_impact_friction(mu).map_err(named)
        } else {
            Ok(c)
        }
    }

    fn frame(&self, name: &str) -> PyResult<usize> {
        self.model.frame_id_of("name", name).map_err(spatial_err)
    }

    /// The model's data after forward kinematics at `q`.
    fn kinematics(&self, q: &[f64]) -> PyResult<SpatialData> {
        let mut data = SpatialData::new(&self.model);
        forward_kinematics(&self.model, &mut data, q).map_err(spatial_err)?;
        Ok(data)
    }

    /// What the contact methods share: `spec` resolved ([`Self::contacts`]), `solve` on the
    /// contacts and fresh data, then a dict that `fill` writes from its result and the data,
    /// with the contact rows under `"rows"`.
    fn contact_dict<'py, T>(
        &self,
        py: Python<'py>,
        spec: &Bound<'_, PyAny>,
        solve: impl FnOnce(&[PointContact], &mut SpatialData) -> Result<T, SpatialError>,
        fill: impl FnOnce(&Bound<'py, PyDict>, T, &SpatialData) -> PyResult<()>,
    ) -> DictOut<'py> {
        guard(|| {
            let (contacts, rows) = self.contacts(spec)?;
            let mut data = SpatialData::new(&self.model);
            let out = solve(&contacts, &mut data).map_err(spatial_err)?;
            let d = PyDict::new(py);
            fill(&d, out, &data)?;
            d.set_item("rows", rows)?;
            Ok(d)
        })
    }
}

#[pymethods]
impl SpatialRobot {
    /// From a URDF file; `base` is `"free_flyer"`, `"planar"` or `"fixed"`
    /// (`BaseKind::from_name`); `root_link` defaults to the
    /// one link that is no joint's child; `frames` adds frames to the URDF's
    /// ([`AddedFrame`]).
    #[staticmethod]
    #[pyo3(signature = (path, base="free_flyer", root_link=None, frames=None))]
    fn from_urdf(
        path: &str,
        base: &str,
        root_link: Option<&str>,
        frames: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard(|| {
            let urdf = std::fs::read_to_string(path).map_err(|e| {
                spatial_err(SpatialError::UrdfParse {
                    message: format!("{path}: {e}"),
                })
            })?;
            Self::from_urdf_text(&urdf, base, root_link, frames)
        })
    }

    /// From URDF text (see `from_urdf`).
    #[staticmethod]
    #[pyo3(signature = (urdf, base="free_flyer", root_link=None, frames=None))]
    fn from_urdf_text(
        urdf: &str,
        base: &str,
        root_link: Option<&str>,
        frames: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<Self> {
        guard(|| {
            UrdfSource {
                urdf: urdf.to_owned(),
                base: base.to_owned(),
                root_link: root_link.map(str::to_owned),
                frames: AddedFrame::parse(frames)?,
            }
            .build()
        })
    }

    /// The six-legged RHex of thesis Table 4.2 (`selfmanip_core::spatial::rhex`), massless
    /// legs by default; the other parameters default to Table 4.2 and the stated assumptions.
    #[staticmethod]
    #[pyo3(signature = (leg_mass_kg=0.0, leg_inertia_kg_m2=0.0, hip_half_width_m=None, base="free_flyer"))]
    fn rhex(
        leg_mass_kg: f64,
        leg_inertia_kg_m2: f64,
        hip_half_width_m: Option<f64>,
        base: &str,
    ) -> PyResult<Self> {
        guard(|| {
            let table = RhexSixLegs::table_4_2();
            let params = RhexSixLegs {
                leg_mass_kg,
                leg_inertia_kg_m2,
                hip_half_width_m: hip_half_width_m.unwrap_or(table.hip_half_width_m),
                ..table
            };
            let urdf = params.urdf().map_err(spatial_err)?;
            Self::from_urdf_text(&urdf, base, None, None)
        })
    }

    /// `pickle` and `copy`: rebuilt from its URDF text, base, root link and added frames.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let py = slf.py();
        let s = &slf.get().source;
        let frames = AddedFrame::to_dict(&s.frames, py)?;
        let args =
            (s.urdf.clone(), s.base.clone(), s.root_link.clone(), frames).into_pyobject(py)?;
        Ok((slf.get_type().getattr("from_urdf_text")?, args))
    }

    #[getter]
    fn name(&self) -> String {
        self.model.name.clone()
    }
    #[getter]
    fn nq(&self) -> usize {
        self.model.nq
    }
    #[getter]
    fn nv(&self) -> usize {
        self.model.nv
    }
    /// Moving joints in order (their coordinates stack in that order).
    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.model.joints.iter().map(|j| j.name.clone()).collect()
    }
    #[getter]
    fn frame_names(&self) -> Vec<String> {
        self.model.frames.iter().map(|f| f.name.clone()).collect()
    }
    #[getter]
    fn gravity(&self) -> Vec<f64> {
        self.model.gravity.as_slice().to_vec()
    }
    #[getter]
    fn total_mass(&self) -> f64 {
        self.model.total_mass()
    }

    fn neutral<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        vec1(py, &neutral(&self.model))
    }

    /// `q ⊕ v`.
    fn integrate<'py>(&self, py: Python<'py>, q: Vec<f64>, v: Vec<f64>) -> VectorOut<'py> {
        vector(py, || integrate(&self.model, &q, &v))
    }

    /// `q1 ⊖ q0`.
    fn difference<'py>(&self, py: Python<'py>, q0: Vec<f64>, q1: Vec<f64>) -> VectorOut<'py> {
        vector(py, || difference(&self.model, &q0, &q1))
    }

    /// Pinocchio's `q` (a continuous joint's `(cos θ, sin θ)`) in this layout (`θ`).
    fn q_from_pinocchio<'py>(&self, py: Python<'py>, q: Vec<f64>) -> VectorOut<'py> {
        vector(py, || from_pinocchio(&self.model, &q))
    }

    /// This layout's `q` in Pinocchio's.
    fn q_to_pinocchio<'py>(&self, py: Python<'py>, q: Vec<f64>) -> VectorOut<'py> {
        vector(py, || to_pinocchio(&self.model, &q))
    }

    /// `M(q)` (nv × nv, CRBA).
    fn mass_matrix<'py>(&self, py: Python<'py>, q: Vec<f64>) -> MatrixOut<'py> {
        guard(|| {
            let mut data = SpatialData::new(&self.model);
            crba(&self.model, &mut data, &q).map_err(spatial_err)?;
            Ok(mat(py, &data.M))
        })
    }

    /// `h(q, v) = C(q, v) v + g(q)` (Pinocchio's `nle`, RNEA).
    fn bias_forces<'py>(&self, py: Python<'py>, q: Vec<f64>, v: Vec<f64>) -> VectorOut<'py> {
        vector(py, || {
            let mut data = SpatialData::new(&self.model);
            nonlinear_effects(&self.model, &mut data, &q, &v)?;
            Ok(data.h)
        })
    }

    /// The frame's placement in the world as a 4 × 4 homogeneous matrix.
    fn frame_placement<'py>(&self, py: Python<'py>, q: Vec<f64>, name: &str) -> MatrixOut<'py> {
        guard(|| {
            let f = self.frame(name)?;
            let data = self.kinematics(&q)?;
            let m = frame_placement(&self.model, &data, f);
            let mut h = DMatrix::identity(4, 4);
            h.view_mut((0, 0), (3, 3)).copy_from(&m.rotation);
            h.view_mut((0, 3), (3, 1)).copy_from(&m.translation);
            Ok(mat(py, &h))
        })
    }

    /// The frame's 6 × nv Jacobian (linear rows first) in `frame`: `"local"` (Pinocchio's
    /// default), `"world"` or `"local_world_aligned"`.
    #[pyo3(signature = (q, name, frame="local"))]
    fn frame_jacobian<'py>(
        &self,
        py: Python<'py>,
        q: Vec<f64>,
        name: &str,
        frame: &str,
    ) -> MatrixOut<'py> {
        guard(|| {
            let f = self.frame(name)?;
            let reference = ReferenceFrame::from_name(frame).map_err(spatial_err)?;
            let mut data = self.kinematics(&q)?;
            frame_jacobian(&self.model, &mut data, f, reference);
            let j = &data.J;
            Ok(Array2::from_shape_fn((6, j.ncols()), |(r, c)| j[(r, c)]).into_pyarray(py))
        })
    }

    /// Constrained forward dynamics (thesis (5.3)–(5.4)) with `contacts` down:
    /// `{"qdd", "lam", "rows", "A", "drift"}` with `M qdd + h = tau + Aᵀ lam` and
    /// `A qdd + drift = 0`.
    #[pyo3(signature = (contacts, q, v, tau, free_qdd=None))]
    fn dynamics<'py>(
        &self,
        py: Python<'py>,
        contacts: &Bound<'py, PyAny>,
        q: Vec<f64>,
        v: Vec<f64>,
        tau: Vec<f64>,
        free_qdd: Option<Vec<f64>>,
    ) -> DictOut<'py> {
        self.contact_dict(
            py,
            contacts,
            |contacts, data| match &free_qdd {
                None => forward_dynamics(&self.model, data, contacts, &q, &v, &tau),
                Some(a) => {
                    forward_dynamics_prescribed(&self.model, data, contacts, a, &q, &v, &tau)
                }
            },
            |d, (), data| {
                d.set_item("qdd", vec1(py, &data.qdd))?;
                d.set_item("lam", vec1(py, &data.lam))?;
                d.set_item("A", mat(py, &data.A))?;
                d.set_item("drift", vec1(py, &data.A_drift))
            },
        )
    }

    /// The blocks of the KKT inverse (thesis (5.2)) of `contacts` at `q`:
    /// `{"m_dagger", "a_dagger", "Lambda", "A", "M", "rows", "free_rates",
    /// "constraint_condition", "reduced_mass_condition"}` (`selfmanip_core::spatial::kkt_blocks`).
    fn kkt<'py>(&self, py: Python<'py>, contacts: &Bound<'py, PyAny>, q: Vec<f64>) -> DictOut<'py> {
        self.contact_dict(
            py,
            contacts,
            |contacts, data| kkt_blocks(&self.model, data, contacts, &q),
            |d, out, data| {
                d.set_item("m_dagger", mat(py, &out.blocks.m_dagger))?;
                d.set_item("a_dagger", mat(py, &out.blocks.a_dagger))?;
                d.set_item("Lambda", mat(py, &out.blocks.lambda))?;
                d.set_item("A", mat(py, &data.A))?;
                d.set_item("M", mat(py, &data.M))?;
                d.set_item("free_rates", out.free_rates.clone())?;
                d.set_item("constraint_condition", out.info.constraint_condition)?;
                d.set_item("reduced_mass_condition", out.info.reduced_mass_condition)
            },
        )
    }

    /// The rates of the massless limbs `contacts` leave in the air, ascending (their
    /// accelerations are `dynamics`'s `free_qdd`).
    fn free_rates(&self, contacts: &Bound<'_, PyAny>) -> PyResult<Vec<usize>> {
        guard(|| {
            let (contacts, _) = self.contacts(contacts)?;
            Ok(free_rates(&self.model, &contacts))
        })
    }

    /// Quasi-static forces (thesis 4.21–4.22) of `contacts` at rest at `q`:
    /// `{"grasp", "gravity_wrench", "lam_external", "internal_basis", "tau_external",
    /// "internal_torques", "rows"}` (see `selfmanip_core::spatial::quasistatic`).
    fn quasi_static<'py>(
        &self,
        py: Python<'py>,
        contacts: &Bound<'py, PyAny>,
        q: Vec<f64>,
    ) -> DictOut<'py> {
        self.contact_dict(
            py,
            contacts,
            |contacts, data| quasi_static(&self.model, data, contacts, &q),
            |d, out, _| {
                d.set_item("grasp", mat(py, &out.grasp))?;
                d.set_item("gravity_wrench", vec1(py, &out.gravity_wrench))?;
                d.set_item("lam_external", vec1(py, &out.lambda_external))?;
                d.set_item("internal_basis", mat(py, &out.internal_basis))?;
                d.set_item("tau_external", vec1(py, &out.tau_external))?;
                d.set_item("internal_torques", mat(py, &out.internal_torques))
            },
        )
    }

    /// Plastic impact (5.10) into `contacts` at `q` with incoming rates `v`:
    /// `{"v_plus", "impulse", "rows", "states"}` with `M (v_plus − v) = Aᵀ impulse`, every
    /// normal velocity after zero; with a friction cone (dict contacts with `friction`) the
    /// Coulomb impact (`spatial::impact_with`), each contact's state `"stick"`, `"slip"`
    /// or `"frictionless"`; with `lift_off` each contact may also leave the ground
    /// (`"separate"`, no impulse, normal velocity after non-negative), by complementarity.
    #[pyo3(signature = (contacts, q, v, lift_off=false))]
    fn impact<'py>(
        &self,
        py: Python<'py>,
        contacts: &Bound<'py, PyAny>,
        q: Vec<f64>,
        v: Vec<f64>,
        lift_off: bool,
    ) -> DictOut<'py> {
        self.contact_dict(
            py,
            contacts,
            |contacts, data| impact_with(&self.model, data, contacts, &q, &v, separation(lift_off)),
            |d, out, _| fill_impact(py, d, &out),
        )
    }

    /// Every outcome of the plastic impact's complementarity into `contacts` (`impact`'s
    /// problem, not asking for a unique one): `{"outcomes": [{"v_plus", "impulse",
    /// "states"}, ...], "rows"}`, distinct in `v_plus`.
    #[pyo3(signature = (contacts, q, v, lift_off=false))]
    fn impact_outcomes<'py>(
        &self,
        py: Python<'py>,
        contacts: &Bound<'py, PyAny>,
        q: Vec<f64>,
        v: Vec<f64>,
        lift_off: bool,
    ) -> DictOut<'py> {
        self.contact_dict(
            py,
            contacts,
            |contacts, data| {
                impact_outcomes(&self.model, data, contacts, &q, &v, separation(lift_off))
            },
            |d, all, _| {
                let list = PyList::empty(py);
                for out in &all {
                    let one = PyDict::new(py);
                    fill_impact(py, &one, out)?;
                    list.append(one)?;
                }
                d.set_item("outcomes", list)
            },
        )
    }
}

/// The separation of an impact with (`lift_off`) or without lift-off.
fn separation(lift_off: bool) -> Separation {
    if lift_off {
        Separation::Allowed
    } else {
        Separation::Forbidden
    }
}

/// `v_plus`, `impulse` and `states` of an impact outcome into `d`.
fn fill_impact<'py>(py: Python<'py>, d: &Bound<'py, PyDict>, out: &SpatialImpact) -> PyResult<()> {
    d.set_item("v_plus", vec1(py, &out.v_plus))?;
    d.set_item("impulse", vec1(py, &out.impulse))?;
    let states: Vec<&str> = out
        .states
        .iter()
        .map(|s| match s {
            ImpactState::Separate => "separate",
            ImpactState::Stick => "stick",
            ImpactState::Slip { .. } => "slip",
            ImpactState::Frictionless => "frictionless",
        })
        .collect();
    d.set_item("states", states)
}

pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<SpatialRobot>()
}
