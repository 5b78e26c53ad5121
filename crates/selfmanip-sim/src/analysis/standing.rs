//! Reactive standing (thesis 4.3.1): the split of joint torques into a mean ("external",
//! fighting gravity) and a difference ("internal", legs fighting each other) part
//! (4.45)–(4.49), and the quasi-static "generalized damper" controller (4.50)–(4.54).
//!
//! Model of the closed loop, for any robot in a stance `mode` with `a = c − 3` internal forces:
//!
//! - torques `τ = τ_p(q) + J_hᵀ f_N α` (4.16), (4.22)–(4.23): `τ_p` is the particular solution
//!   with no locked component (`t_dᵀ τ_p = 0`, as (4.48)), `f_N` spans `ker G_s`;
//! - the split `[τ_m; τ_d] = T τ` with `T` the thesis's `½[[1, 1], [1, −1]]` (4.45) for RHex,
//!   or an orthogonal split into free and locked joint directions for another robot;
//! - the velocity-controlled motors (4.50)–(4.52): the free motion follows
//!   `ẏ = κ_p θ̃_m` exactly along `H` (4.20) with `y = t_mᵀθ`, while a command in the locked
//!   directions winds up torque, `τ̇_d = κ_t θ̃_d`;
//! - the controller `θ̃_m = sat(κ_m τ_m)`, `θ̃_d = sat(−κ_d τ_d)` with `|·| ≤ κ_σ` (4.53)–(4.54).
//!
//! Costs: `ε = |τ_m|²` (external), `δ = |τ_d|²` (internal).
//! Contact normals need not be vertical (assumption C.5 dropped): [`TwoPlaneTerrain`].
use super::{bad, check_finite, free_motion_basis};
use crate::error::SimError;
use nalgebra::{DMatrix, DVector};
use selfmanip_core::quasistatic::quasi_static;
use selfmanip_core::{ContactMode, Data, GroundPlane, Model, Terrain};
use serde::Serialize;

/// Rough terrain for a two-ended stance: one ground plane ahead of `split_x_m`, another behind.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct TwoPlaneTerrain {
    pub split_x_m: f64,
    pub front: GroundPlane,
    pub rear: GroundPlane,
}

impl Terrain for TwoPlaneTerrain {
    fn plane_under(&self, x_m: f64) -> GroundPlane {
        if x_m >= self.split_x_m {
            self.front
        } else {
            self.rear
        }
    }
}

/// A plane through world point `(x, z)` rising by `slope_rad` towards `+x` (nose-up slope).
pub fn sloped_plane(x_m: f64, z_m: f64, slope_rad: f64) -> GroundPlane {
    // tangent (cos s, −sin s) (z down: rising ahead); normal into the ground ⟂ tangent, z > 0
    GroundPlane {
        point_m: [x_m, z_m],
        normal_into_ground: [slope_rad.sin(), slope_rad.cos()],
    }
}

/// `[τ_m; τ_d] = T τ`; the first `n_mean` rows of `T` are the mean (free) directions.
#[derive(Debug, Clone, Serialize)]
pub struct TorqueSplit {
    pub t: DMatrix<f64>,
    pub n_mean: usize,
}

impl TorqueSplit {
    /// The mean and difference of two joints, the thesis's (4.45) for RHex:
    /// `T = ½ [[1, 1], [1, −1]]`.
    pub fn mean_difference() -> Self {
        TorqueSplit {
            t: DMatrix::from_row_slice(2, 2, &[0.5, 0.5, 0.5, -0.5]),
            n_mean: 1,
        }
    }

    /// For any robot: orthonormal rows spanning the joint part of the free motions
    /// (`range H_θ`, from `ker A` at `q`) first, then its orthogonal complement (locked).
    pub fn from_free_motion(
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        q: &[f64],
    ) -> Result<Self, SimError> {
        let nq = model.nq();
        let n = model.n_joints();
        let mut data = Data::new(model);
        data.prepare_geometry(model, terrain, mode, q, &vec![0.0; nq])?;
        let a = data.constraints.a.clone();
        // ker A from the full SVD of Aᵀ A
        let eig = nalgebra::SymmetricEigen::new(a.transpose() * &a);
        let scale = eig.eigenvalues.max().max(1e-300);
        let null: Vec<usize> = (0..nq)
            .filter(|&i| eig.eigenvalues[i] < 1e-10 * scale)
            .collect();
        let mut h_theta = DMatrix::zeros(n, null.len());
        for (c, &i) in null.iter().enumerate() {
            h_theta.set_column(c, &eig.eigenvectors.column(i).rows(0, n));
        }
        // joint-space basis: eigenvectors of H_θ H_θᵀ, largest first
        let e2 = nalgebra::SymmetricEigen::new(&h_theta * h_theta.transpose());
        let mut order: Vec<usize> = (0..n).collect();
        order.sort_by(|&i, &j| e2.eigenvalues[j].total_cmp(&e2.eigenvalues[i]));
        let smax = e2.eigenvalues.max().max(1e-300);
        let n_mean = order
            .iter()
            .filter(|&&i| e2.eigenvalues[i] > 1e-10 * smax)
            .count();
        let mut t = DMatrix::zeros(n, n);
        for (r, &i) in order.iter().enumerate() {
            t.set_row(r, &e2.eigenvectors.column(i).transpose());
        }
        Ok(TorqueSplit { t, n_mean })
    }

    fn mean_rows(&self) -> DMatrix<f64> {
        self.t.rows(0, self.n_mean).into_owned()
    }
    fn lock_rows(&self) -> DMatrix<f64> {
        let n = self.t.nrows();
        self.t.rows(self.n_mean, n - self.n_mean).into_owned()
    }
}

/// Controller and actuator constants of (4.50)–(4.54).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct StandingGains {
    /// Velocity loop gain `κ_p` (1/s).
    pub kappa_p: f64,
    /// Torque wind-up per locked command `κ_t` (N m / rad).
    pub kappa_t: f64,
    /// Mean-torque gain `κ_m` (rad / N m).
    pub kappa_m: f64,
    /// Difference-torque gain `κ_d` (rad / N m).
    pub kappa_d: f64,
    /// Command rate limit `κ_σ` (rad).
    pub kappa_sigma: f64,
}

impl Default for StandingGains {
    fn default() -> Self {
        StandingGains {
            kappa_p: 2.0,
            kappa_t: 20.0,
            kappa_m: 0.1,
            kappa_d: 0.1,
            kappa_sigma: 0.3,
        }
    }
}

/// Time series of a reactive stand.
#[derive(Debug, Clone, Serialize)]
pub struct StandingTrace {
    pub t: Vec<f64>,
    /// External cost `ε = |τ_m|²`.
    pub epsilon: Vec<f64>,
    /// Internal cost `δ = |τ_d|²`.
    pub delta: Vec<f64>,
    /// Joint torques.
    pub tau: Vec<Vec<f64>>,
    /// Generalized coordinates.
    pub q: Vec<Vec<f64>>,
    /// Largest |gap| of the stance contacts along the run (constraint drift, m).
    pub max_gap_m: f64,
}

struct Eval {
    qd: DVector<f64>,
    sd: DVector<f64>,
    tau: DVector<f64>,
}

fn sat(v: f64, lim: f64) -> f64 {
    v.clamp(-lim, lim)
}

/// Simulates the reactive stand from `q0` (a stance in `mode` on `terrain`) with initial
/// locked torques `tau_d0` (the internal "fight" between the legs), for `steps` RK4 steps of
/// `dt_s`.
#[allow(clippy::too_many_arguments)]
pub fn simulate_standing(
    model: &Model,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q0: &[f64],
    tau_d0: &[f64],
    split: &TorqueSplit,
    gains: &StandingGains,
    dt_s: f64,
    steps: usize,
) -> Result<StandingTrace, SimError> {
    let n = model.n_joints();
    let nq = model.nq();
    check_finite("q0", q0)?;
    check_finite("tau_d0", tau_d0)?;
    if q0.len() != nq {
        return Err(bad("q0", format!("expected {nq} coordinates")));
    }
    if split.t.shape() != (n, n) || split.n_mean == 0 || split.n_mean > n {
        return Err(bad(
            "split",
            format!("T must be {n}×{n} with 1..={n} mean rows"),
        ));
    }
    let c = mode.n_rows();
    let a = c
        .checked_sub(3)
        .ok_or_else(|| bad("mode", "a stance needs at least three contact rows"))?;
    if a != n - split.n_mean {
        return Err(bad(
            "split",
            format!(
                "{a} internal forces but {} locked directions",
                n - split.n_mean
            ),
        ));
    }
    if nq - c != split.n_mean {
        return Err(bad(
            "split",
            format!("{} free motions but {} mean rows", nq - c, split.n_mean),
        ));
    }
    if tau_d0.len() != a {
        return Err(bad("tau_d0", format!("expected {a} entries")));
    }
    let g = *gains;
    for (f, v) in [
        ("kappa_p", g.kappa_p),
        ("kappa_t", g.kappa_t),
        ("kappa_m", g.kappa_m),
        ("kappa_d", g.kappa_d),
        ("kappa_sigma", g.kappa_sigma),
    ] {
        if !(v > 0.0 && v.is_finite()) {
            return Err(bad(f, "must be positive and finite"));
        }
    }
    if dt_s.is_nan() || dt_s <= 0.0 {
        return Err(bad("dt_s", "must be positive"));
    }
    let tm = split.mean_rows();
    let tl = split.lock_rows();
    let t_lock = tl.transpose();
    let mut y_map = DMatrix::zeros(split.n_mean, nq);
    y_map.view_mut((0, 0), (split.n_mean, n)).copy_from(&tm);
    let mut data = Data::new(model);
    let mut eval = |q: &[f64], s: &DVector<f64>| -> Result<Eval, SimError> {
        // (q, τ_d) ⇒ τ = τ_p + J_hᵀ f_N α with t_dᵀ τ = τ_d
        let qs = quasi_static(model, &mut data, terrain, mode, q, &t_lock)?;
        let tn = &qs.balance.internal_torques;
        let alpha = (&tl * tn)
            .lu()
            .solve(s)
            .ok_or_else(|| bad("q", "internal forces exert no locked torque here"))?;
        let tau = &qs.balance.tau_particular + tn * alpha;
        // controller (4.53)–(4.54)
        let tau_m = &tm * &tau;
        let yd = tau_m.map(|v| g.kappa_p * sat(g.kappa_m * v, g.kappa_sigma));
        let sd = s.map(|v| g.kappa_t * sat(-g.kappa_d * v, g.kappa_sigma));
        // free motion (4.20), (4.50)
        let h = free_motion_basis(model, terrain, mode, q, &y_map)?;
        Ok(Eval {
            qd: h * yd,
            sd,
            tau,
        })
    };
    let contacts: Vec<usize> = mode.active().collect();
    let mut q = DVector::from_column_slice(q0);
    let mut s = DVector::from_column_slice(tau_d0);
    let mut trace = StandingTrace {
        t: vec![],
        epsilon: vec![],
        delta: vec![],
        tau: vec![],
        q: vec![],
        max_gap_m: 0.0,
    };
    for i in 0..=steps {
        let e1 = eval(q.as_slice(), &s)?;
        let tau_m = &tm * &e1.tau;
        let tau_d = &tl * &e1.tau;
        trace.t.push(i as f64 * dt_s);
        trace.epsilon.push(tau_m.norm_squared());
        trace.delta.push(tau_d.norm_squared());
        trace.tau.push(e1.tau.iter().cloned().collect());
        trace.q.push(q.iter().cloned().collect());
        let gaps = super::contact_gaps(model, terrain, &contacts, q.as_slice());
        trace.max_gap_m = gaps.iter().fold(trace.max_gap_m, |m, v| m.max(v.abs()));
        if i == steps {
            break;
        }
        let h = dt_s;
        let e2 = eval(
            (&q + &e1.qd * (0.5 * h)).as_slice(),
            &(&s + &e1.sd * (0.5 * h)),
        )?;
        let e3 = eval(
            (&q + &e2.qd * (0.5 * h)).as_slice(),
            &(&s + &e2.sd * (0.5 * h)),
        )?;
        let e4 = eval((&q + &e3.qd * h).as_slice(), &(&s + &e3.sd * h))?;
        q += (&e1.qd + &e2.qd * 2.0 + &e3.qd * 2.0 + &e4.qd) * (h / 6.0);
        s += (&e1.sd + &e2.sd * 2.0 + &e3.sd * 2.0 + &e4.sd) * (h / 6.0);
        check_finite("state", q.as_slice())?;
    }
    Ok(trace)
}
