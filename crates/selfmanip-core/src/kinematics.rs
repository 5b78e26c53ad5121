//! Forward kinematics of the planar tree: link poses and velocities, point Jacobians and
//! their exact time derivatives (closed forms; no finite differences).
//!
//! Every angle in a planar tree is a sum of coordinates (`β_j = φ + Σ_{k≤j} s_k θ_k`), so for
//! a point `p` on part `b` the Jacobian column of a coordinate that rotates `b` about the
//! point `o` is `s S(p − o)`, and its time derivative is `s S(ṗ − ȯ)` where `ṗ` is the rate of
//! the point at which the Jacobian is evaluated (the material velocity for a fixed point,
//! the centre's velocity for a rolling contact on a plane).
use crate::arc_range::ArcRange;
use crate::frames::{perp, rotate_sc};
use crate::model::{ContactShape, Model};
use nalgebra::{DMatrix, Vector2};

/// The rigid part a point belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Part {
    Body,
    /// The link driven by joint `j`.
    Link(usize),
}

/// Poses and velocities of all parts at one `(q, q̇)`.
#[derive(Debug, Clone, Default)]
pub struct Kinematics {
    pub body_pos: Vector2<f64>,
    pub body_vel: Vector2<f64>,
    pub phi: f64,
    pub phi_dot: f64,
    /// World position of joint `j` (the origin of link `j`).
    pub origin: Vec<Vector2<f64>>,
    pub origin_vel: Vec<Vector2<f64>>,
    /// World angle of link `j` about `+y`.
    pub beta: Vec<f64>,
    pub beta_dot: Vec<f64>,
    /// `(sin, cos)` of `φ` and of every `β_j` (each computed once per evaluation).
    body_sc: (f64, f64),
    link_sc: Vec<(f64, f64)>,
    /// The normal range of every contact arc that has one (by contact), with its end normals:
    /// constants of the model, recomputed only when the model's ranges change.
    arcs: Vec<Option<ArcRange>>,
}

impl Kinematics {
    /// Recomputes every pose and velocity (no allocation after the first call).
    pub fn compute(&mut self, model: &Model, q: &[f64], qd: &[f64]) {
        self.compute_where(model, q, qd, |_| true);
    }

    /// [`Self::compute`] for the body and the legs of `legs` only (bit `l` for leg `l`; a
    /// leg from the 64th on is always computed): what the geometry of contacts on those
    /// legs and on the body reads. The other legs' poses and velocities are left as they
    /// were, so that these kinematics answer only for those contacts. The values computed
    /// are those of [`Self::compute`], bit for bit (each leg starts from its hip).
    pub fn compute_legs(&mut self, model: &Model, q: &[f64], qd: &[f64], legs: u64) {
        self.compute_where(model, q, qd, |leg| leg >= 64 || legs >> leg & 1 == 1);
    }

    #[inline(always)]
    fn compute_where(
        &mut self,
        model: &Model,
        q: &[f64],
        qd: &[f64],
        computed: impl Fn(usize) -> bool,
    ) {
        let n = model.n_joints();
        if self.link_sc.len() != n {
            self.origin.resize(n, Vector2::zeros());
            self.origin_vel.resize(n, Vector2::zeros());
            self.beta.resize(n, 0.0);
            self.beta_dot.resize(n, 0.0);
            self.link_sc.resize(n, (0.0, 1.0));
        }
        self.arcs.resize(model.n_contacts(), None);
        for (arc, contact) in self.arcs.iter_mut().zip(&model.contacts) {
            let range = match contact.shape {
                ContactShape::Arc {
                    normal_range_rad, ..
                } => normal_range_rad,
                ContactShape::Point { .. } => None,
            };
            if arc.map(|a| a.range) != range {
                *arc = range.map(ArcRange::new);
            }
        }
        let (q_joints, q_body) = q.split_at(n);
        let (qd_joints, qd_body) = qd.split_at(n);
        let (x, xd) = (
            Vector2::new(q_body[0], q_body[1]),
            Vector2::new(qd_body[0], qd_body[1]),
        );
        let (phi, phi_dot, body_sc) = (q_body[2], qd_body[2], q_body[2].sin_cos());
        (self.body_pos, self.body_vel) = (x, xd);
        (self.phi, self.phi_dot, self.body_sc) = (phi, phi_dot, body_sc);
        // the joints leg by leg, proximal to distal: each leg's first starts at its hip
        let inputs = model.joints.iter().zip(q_joints).zip(qd_joints);
        let poses = self
            .origin
            .iter_mut()
            .zip(&mut self.beta)
            .zip(&mut self.link_sc);
        let rates = self.origin_vel.iter_mut().zip(&mut self.beta_dot);
        let (mut o, mut od, mut b, mut bd) = (x, xd, phi, phi_dot);
        for (((joint, &qj), &qdj), (((origin, beta), sc), (origin_vel, beta_dot))) in
            inputs.zip(poses.zip(rates))
        {
            if !computed(joint.leg) {
                continue;
            }
            if joint.index_in_leg == 0 {
                // hip: o = X + R(φ) h,  ȯ = Ẋ + φ̇ S(R(φ) h)
                let rh = rotate_sc(body_sc, model.legs[joint.leg].hip_m);
                o = x + rh;
                od = xd + phi_dot * perp(rh);
                b = phi;
                bd = phi_dot;
            }
            b += joint.axis_sign * qj;
            bd += joint.axis_sign * qdj;
            *origin = o;
            *origin_vel = od;
            *beta = b;
            *beta_dot = bd;
            *sc = b.sin_cos();
            // next joint at the link's tip
            let tip = rotate_sc(*sc, Vector2::new(0.0, joint.length_m));
            o += tip;
            od += bd * perp(tip);
        }
    }

    /// [`CoreError::NonFiniteResult`](crate::CoreError::NonFiniteResult) unless every pose
    /// and velocity of the last [`Self::compute`] is finite: finite `(q, q̇)` near the
    /// largest `f64` (angles of 1e308 summed along a leg) overflow to inf and NaN.
    pub fn check_finite(&self) -> crate::error::Result<()> {
        let vectors = [self.body_pos, self.body_vel]
            .into_iter()
            .chain(self.origin.iter().copied())
            .chain(self.origin_vel.iter().copied());
        let finite = vectors.flat_map(|v| [v.x, v.y]).all(f64::is_finite)
            && [self.phi, self.phi_dot]
                .iter()
                .chain(&self.beta)
                .chain(&self.beta_dot)
                .all(|v| v.is_finite());
        if finite {
            Ok(())
        } else {
            Err(crate::CoreError::NonFiniteResult {
                quantity: "poses and velocities of the parts at (q, q̇)",
            })
        }
    }

    pub fn part_angle(&self, part: Part) -> f64 {
        match part {
            Part::Body => self.phi,
            Part::Link(j) => self.beta[j],
        }
    }

    /// `(sin, cos)` of the part's world angle.
    pub fn part_sin_cos(&self, part: Part) -> (f64, f64) {
        match part {
            Part::Body => self.body_sc,
            Part::Link(j) => self.link_sc[j],
        }
    }

    /// The normal range of contact `k`'s arc, as of the model of the last [`Self::compute`].
    pub(crate) fn arc_range(&self, k: usize) -> Option<ArcRange> {
        self.arcs.get(k).copied().flatten()
    }

    pub fn part_angle_rate(&self, part: Part) -> f64 {
        match part {
            Part::Body => self.phi_dot,
            Part::Link(j) => self.beta_dot[j],
        }
    }

    pub fn part_origin(&self, part: Part) -> Vector2<f64> {
        match part {
            Part::Body => self.body_pos,
            Part::Link(j) => self.origin[j],
        }
    }

    /// World position of a point given in the part's frame.
    pub fn point(&self, part: Part, local: Vector2<f64>) -> Vector2<f64> {
        self.part_origin(part) + rotate_sc(self.part_sin_cos(part), local)
    }

    /// Material velocity of the part's point currently at world position `p`.
    pub fn material_velocity(&self, part: Part, p: Vector2<f64>) -> Vector2<f64> {
        let (o, od) = match part {
            Part::Body => (self.body_pos, self.body_vel),
            Part::Link(j) => (self.origin[j], self.origin_vel[j]),
        };
        od + self.part_angle_rate(part) * perp(p - o)
    }

    /// The joints that move `part`: its chain (none for the body). With the body pose
    /// `x, z, φ` they are the only columns where its Jacobians can be nonzero.
    fn chain(model: &Model, part: Part) -> std::ops::Range<usize> {
        match part {
            Part::Body => 0..0,
            Part::Link(j) => *model.chain(j).start()..j + 1,
        }
    }

    /// Calls `f(k, J_p e_k)` for the nonzero columns of the 2×nq translational Jacobian of
    /// the material point of `part` at world position `p`, in ascending `k`: the chain's
    /// joints, then `x, z, φ`. (Visiting rather than returning an iterator keeps this
    /// straight-line code in the hot loops.)
    #[inline]
    pub(crate) fn point_jacobian_columns(
        &self,
        model: &Model,
        part: Part,
        p: Vector2<f64>,
        mut f: impl FnMut(usize, Vector2<f64>),
    ) {
        Self::joint_columns(model, part, p, &self.origin, &mut f);
        let n = model.n_joints();
        f(n, Vector2::new(1.0, 0.0));
        f(n + 1, Vector2::new(0.0, 1.0));
        f(n + 2, perp(p - self.body_pos));
    }

    /// Calls `f(k, J̇_p e_k)` for the nonzero columns of the time derivative of the point
    /// Jacobian when the evaluation point moves with velocity `p_dot`: the chain's joints,
    /// then `φ`.
    #[inline]
    pub(crate) fn point_jacobian_rate_columns(
        &self,
        model: &Model,
        part: Part,
        p_dot: Vector2<f64>,
        mut f: impl FnMut(usize, Vector2<f64>),
    ) {
        Self::joint_columns(model, part, p_dot, &self.origin_vel, &mut f);
        f(model.n_joints() + 2, perp(p_dot - self.body_vel));
    }

    /// The joint columns of [`Self::point_jacobian_columns`] (`origins`: the joints'
    /// positions, `p` the point's) and of [`Self::point_jacobian_rate_columns`] (their
    /// velocities, `p` the point's): `f(k, σ_k (p − o_k)^⊥)` along the chain to `part`.
    #[inline]
    fn joint_columns(
        model: &Model,
        part: Part,
        p: Vector2<f64>,
        origins: &[Vector2<f64>],
        f: &mut impl FnMut(usize, Vector2<f64>),
    ) {
        for k in Self::chain(model, part) {
            f(k, model.joints[k].axis_sign * perp(p - origins[k]));
        }
    }

    /// Calls `f(k, J_p e_k, J̇_p e_k, J_ω e_k)` for the joints of `part`'s chain, ascending,
    /// and returns `(J_p e_φ, J̇_p e_φ)` (`J_ω e_φ = 1`): the columns that rotate `part`, at
    /// the material point at `p` moving with `p_dot` — the entries of
    /// [`Self::point_jacobian_columns`], [`Self::point_jacobian_rate_columns`] and
    /// [`Self::angular_jacobian_entries`] but those of `x, z`, which only translate it
    /// (`J e_x = (1, 0)`, `J e_z = (0, 1)`, no rate, no rotation).
    #[inline]
    pub(crate) fn rotation_columns(
        &self,
        model: &Model,
        part: Part,
        p: Vector2<f64>,
        p_dot: Vector2<f64>,
        mut f: impl FnMut(usize, Vector2<f64>, Vector2<f64>, f64),
    ) -> (Vector2<f64>, Vector2<f64>) {
        for k in Self::chain(model, part) {
            let s = model.joints[k].axis_sign;
            f(
                k,
                s * perp(p - self.origin[k]),
                s * perp(p_dot - self.origin_vel[k]),
                s,
            );
        }
        (perp(p - self.body_pos), perp(p_dot - self.body_vel))
    }

    /// Calls `f(k, J_ω e_k)` for the nonzero entries of the angular Jacobian row of a part:
    /// the chain's joints, then `φ`.
    #[inline]
    pub(crate) fn angular_jacobian_entries(
        &self,
        model: &Model,
        part: Part,
        mut f: impl FnMut(usize, f64),
    ) {
        for k in Self::chain(model, part) {
            f(k, model.joints[k].axis_sign);
        }
        f(model.n_joints() + 2, 1.0);
    }

    /// Writes the 2×nq Jacobian of the material point of `part` at world position `p`
    /// (projected on the unit direction `d`) into `row`: `row = dᵀ J_p`.
    pub fn point_jacobian_row(
        &self,
        model: &Model,
        part: Part,
        p: Vector2<f64>,
        d: Vector2<f64>,
        row: &mut [f64],
    ) {
        row.fill(0.0);
        self.point_jacobian_columns(model, part, p, |k, col| row[k] = d.dot(&col));
    }

    /// Time derivative of [`Self::point_jacobian_row`] when the evaluation point moves with
    /// velocity `p_dot` (and `d` is constant in the world).
    pub fn point_jacobian_rate_row(
        &self,
        model: &Model,
        part: Part,
        p_dot: Vector2<f64>,
        d: Vector2<f64>,
        row: &mut [f64],
    ) {
        row.fill(0.0);
        self.point_jacobian_rate_columns(model, part, p_dot, |k, col| row[k] = d.dot(&col));
    }

    /// Angular Jacobian row of a part: `ω = row · q̇`.
    pub fn angular_jacobian_row(&self, model: &Model, part: Part, row: &mut [f64]) {
        row.fill(0.0);
        self.angular_jacobian_entries(model, part, |k, w| row[k] = w);
    }

    /// Full 2×nq translational Jacobian of a material point (rows: world x, z).
    pub fn point_jacobian(&self, model: &Model, part: Part, p: Vector2<f64>) -> DMatrix<f64> {
        let nq = model.nq();
        let mut j = DMatrix::zeros(2, nq);
        let mut row = vec![0.0; nq];
        for (r, d) in [Vector2::new(1.0, 0.0), Vector2::new(0.0, 1.0)]
            .into_iter()
            .enumerate()
        {
            self.point_jacobian_row(model, part, p, d, &mut row);
            for c in 0..nq {
                j[(r, c)] = row[c];
            }
        }
        j
    }
}
