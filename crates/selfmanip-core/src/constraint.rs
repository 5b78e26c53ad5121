//! The velocity constraint `A` of thesis (4.11)/(4.17) and its time derivative `Ȧ`, for the
//! rows of one contact mode: `A_k = −Bᵀ J_p` at the contact point, `Ȧ_k = −Ḃᵀ J_p − Bᵀ J̇_p`
//! (`Ḃ = 0` on a plane; on a terrain corner the contact frame turns with the site; see
//! [`crate::contact`] for the frame and rolling conventions).
use crate::contact::{
    contact_geometry, row_direction, row_direction_rate, ConstraintRow, ContactGeometry,
    ContactMode, Terrain,
};
use crate::kinematics::Kinematics;
use crate::model::Model;
use nalgebra::{DMatrix, DVector};

/// `A`, `Ȧ` and `Ȧ q̇` for a mode, with the row layout.
#[derive(Debug, Clone, Default)]
pub struct Constraints {
    pub rows: Vec<ConstraintRow>,
    /// Geometry of each active contact, in `mode.active()` order.
    pub geometry: Vec<(usize, ContactGeometry)>,
    pub a: DMatrix<f64>,
    pub a_dot: DMatrix<f64>,
    pub a_dot_qd: DVector<f64>,
}

/// The geometry of the active contact `contact` among `geometry` (as
/// [`Constraints::geometry`]).
#[inline]
pub(crate) fn geometry_of(
    geometry: &[(usize, ContactGeometry)],
    contact: usize,
) -> &ContactGeometry {
    &geometry
        .iter()
        .find(|(k, _)| *k == contact)
        .expect("active contact")
        .1
}

impl Constraints {
    /// Rebuilds every row for `mode` at the current kinematics (allocates only when the
    /// number of rows grows).
    pub fn assemble(
        &mut self,
        model: &Model,
        kin: &Kinematics,
        terrain: &dyn Terrain,
        mode: ContactMode,
        qd: &[f64],
    ) {
        let nq = model.nq();
        let c = mode.n_rows();
        self.rows.clear();
        self.rows.extend(mode.rows());
        self.geometry.clear();
        self.geometry.extend(
            mode.active()
                .map(|k| (k, contact_geometry(model, kin, terrain, k))),
        );
        if self.a.shape() != (c, nq) {
            // resized in their own buffers (every entry is written below): a workspace
            // that moves between modes of different sizes allocates only to grow
            let reshape = |m: &mut DMatrix<f64>| {
                let mut buf: Vec<f64> = std::mem::replace(m, DMatrix::zeros(0, 0)).data.into();
                buf.clear();
                buf.resize(c * nq, 0.0);
                *m = DMatrix::from_vec(c, nq, buf);
            };
            reshape(&mut self.a);
            reshape(&mut self.a_dot);
            let mut buf: Vec<f64> = std::mem::replace(&mut self.a_dot_qd, DVector::zeros(0))
                .data
                .into();
            buf.clear();
            buf.resize(c, 0.0);
            self.a_dot_qd = DVector::from_vec(buf);
        }
        // A and Ȧ are c×nq column-major, entry (r, k) at k·c + r; a row is nonzero only on
        // its contact part's support
        let (a, a_dot) = (self.a.as_mut_slice(), self.a_dot.as_mut_slice());
        a.fill(0.0);
        a_dot.fill(0.0);
        for (r, row) in self.rows.iter().enumerate() {
            let geo = geometry_of(&self.geometry, row.contact);
            let d = row_direction(&geo.plane, row.direction);
            let d_rate = row_direction_rate(geo.normal_rate, row.direction);
            let turning = d_rate != nalgebra::Vector2::zeros();
            let mut acc = 0.0;
            kin.point_jacobian_columns(model, geo.part, geo.point, |k, col| {
                a[k * c + r] = -d.dot(&col);
                if turning {
                    let v = d_rate.dot(&col);
                    a_dot[k * c + r] -= v;
                    acc -= v * qd[k];
                }
            });
            kin.point_jacobian_rate_columns(model, geo.part, geo.point_rate, |k, col| {
                let v = d.dot(&col);
                a_dot[k * c + r] -= v;
                acc -= v * qd[k];
            });
            self.a_dot_qd[r] = acc;
        }
    }

    pub fn n_rows(&self) -> usize {
        self.rows.len()
    }
}
