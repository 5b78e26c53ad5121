//! The constrained dynamics of thesis (5.3)–(5.4) and the plastic impact (5.10), read as a
//! pipeline on a reusable [`Data`] workspace (Pinocchio's `(model, data, …)`):
//!
//! ```text
//! (q, q̇)      => kinematics            (link poses, velocities)
//!             => inertia               (M̄, C̄q̇, N̄)
//!             => constraints(mode)     (A, Ȧ, Ȧq̇)
//!             => free massless joints  (dropped: no inertia, no contact)
//!             => KKT factor            (M†, A†, Λ; Lemma 5.1)
//! (τ)         => solve                 (q̈, λ)
//! ```
//!
//! **Massless limbs out of contact.** A joint whose whole distal chain is massless and
//! carries no active contact has no dynamics (thesis 5.1.1, footnote 3): its motion is
//! prescribed, not computed. Such joints are removed from the KKT system; their `q̈` is the
//! prescribed acceleration (`free_joint_qdd`, default 0) and their torque does no work.
//!
//! **Locked massless joints.** A caller may also prescribe the motion of massless joints
//! that *are* in contact ([`Data::locked`]; the hybrid engine does so while a leg passes the
//! fold of its contact, where its contact cannot pin it). They are removed from the KKT
//! system like free joints, but their constraint columns stay: their prescribed velocity and
//! acceleration enter the constraint's right-hand side, `A_d q̈_d = −Ȧq̇ − A_ℓ q̈_ℓ`.
use crate::contact::{ContactMode, Terrain};
pub use crate::data::Data;
use crate::data::FreeJointsKey;
use crate::error::{check_result, check_vector, Result, SingularityKind};
use crate::inertia::mass_coriolis_gravity;
use crate::model::Model;
use nalgebra::DVector;

impl Data {
    /// Every stage of [`Data::prepare`] before the solve — kinematics, `M̄ C̄ N̄`, `A Ȧ` — for
    /// callers that need only these: a singular KKT matrix (Lemma 5.1) is not an error here,
    /// since the factorization is the last stage and the others are complete without it.
    pub fn prepare_geometry(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<()> {
        match self.prepare(model, terrain, mode, q, qd) {
            Ok(()) | Err(crate::CoreError::SingularKkt { .. }) => Ok(()),
            Err(e) => Err(e),
        }
    }

    /// Runs every stage up to and including the KKT factorization.
    pub fn prepare(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        q: &[f64],
        qd: &[f64],
    ) -> Result<()> {
        let nq = model.nq();
        check_vector("q", q, nq)?;
        check_vector("qd", qd, nq)?;
        mode.validate(model)?;
        self.state_stages(model, q, qd)?;
        self.mode_stages(model, terrain, mode, qd)?;
        // => factor [M̄ Aᵀ; A 0] on the dynamic coordinates
        self.kkt
            .factor_on(&self.m_bar, &self.constraints.a, &self.dynamic_coords)
    }

    /// [`Self::prepare`] at the state of the last [`Self::prepare`] or
    /// [`Self::prepare_state`], which must have been at the same `(q, q̇)` (`qd` here): the
    /// stages of `mode` and the KKT factor only, with `prepare`'s result — for a caller that
    /// evaluates another mode, time or controller at a state it has just prepared.
    pub fn prepare_at_state(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        qd: &[f64],
    ) -> Result<()> {
        self.checked_mode_stages(model, terrain, mode, qd)?;
        self.kkt
            .factor_on(&self.m_bar, &self.constraints.a, &self.dynamic_coords)
    }

    /// The stages of [`Self::prepare`] that depend on the state `(q, q̇)` alone — kinematics,
    /// `M̄ C̄q̇ N̄` —: what every candidate mode at one event shares. [`Self::prepare_mode`]
    /// then runs the rest for each mode.
    pub fn prepare_state(&mut self, model: &Model, q: &[f64], qd: &[f64]) -> Result<()> {
        check_vector("q", q, model.nq())?;
        check_vector("qd", qd, model.nq())?;
        self.state_stages(model, q, qd)
    }

    /// The stages of [`Self::prepare`] that depend on `mode` — `A Ȧ`, the sliding sites, the
    /// free joints, the KKT factor — at the state of the last [`Self::prepare_state`] or
    /// [`Self::prepare`], which must have been at the same `q̇ = qd` (and `q`); the same
    /// result as `prepare` at that state. A singular KKT matrix (Lemma 5.1) is the inner
    /// error, its kind only: [`Self::prepare`]'s error also carries the matrix's condition
    /// number, an SVD, which a caller that discards the error need not pay for.
    pub fn prepare_mode(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        qd: &[f64],
    ) -> Result<std::result::Result<(), SingularityKind>> {
        self.checked_mode_stages(model, terrain, mode, qd)?;
        Ok(self
            .kkt
            .try_factor_on(&self.m_bar, &self.constraints.a, &self.dynamic_coords))
    }

    /// The stages of `mode` at the prepared state, its inputs checked: what
    /// [`Self::prepare_at_state`] and [`Self::prepare_mode`] run before their factor.
    fn checked_mode_stages(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        qd: &[f64],
    ) -> Result<()> {
        check_vector("qd", qd, model.nq())?;
        mode.validate(model)?;
        debug_assert_eq!(
            self.m_bar.shape(),
            (model.nq(), model.nq()),
            "state not prepared"
        );
        self.mode_stages(model, terrain, mode, qd)
    }

    /// Kinematics and `M̄ C̄q̇ N̄` at `(q, q̇)` (checked by the caller).
    fn state_stages(&mut self, model: &Model, q: &[f64], qd: &[f64]) -> Result<()> {
        let nq = model.nq();
        if self.m_bar.shape() != (nq, nq) {
            *self = Data::new(model);
        }
        // (q, q̇) => poses, velocities
        self.kin.compute(model, q, qd);
        // => M̄, C̄q̇, N̄
        mass_coriolis_gravity(
            model,
            &self.kin,
            qd,
            &mut self.scratch,
            &mut self.m_bar,
            &mut self.c_qd,
            &mut self.n_bar,
        );
        // springs, dampers
        crate::passive::add_passive_bias(model, q, qd, &mut self.n_bar);
        // finite inputs too large for double precision overflow here, not as a singular
        // KKT matrix further on
        check_result("M̄", self.m_bar.as_slice())?;
        check_result("C̄q̇", self.c_qd.as_slice())?;
        check_result("N̄", self.n_bar.as_slice())
    }

    /// Every stage of `mode` before the KKT factor: `A Ȧ`, the sliding sites, the free and
    /// locked joints.
    fn mode_stages(
        &mut self,
        model: &Model,
        terrain: &dyn Terrain,
        mode: ContactMode,
        qd: &[f64],
    ) -> Result<()> {
        // => the damped slides, out of the KKT system (crate::damped_slide)
        // (a robot without such a chain has no laws and never a split: nothing to clear)
        let mode = if self.damped_laws.is_empty() && self.damped_modes.is_none() {
            mode
        } else {
            crate::damped_slide::split(model, self, terrain, mode, qd)?
        };
        // => A, Ȧ, Ȧq̇
        self.constraints
            .assemble(model, &self.kin, terrain, mode, qd);
        check_result("A", self.constraints.a.as_slice())?;
        check_result("Ȧq̇", self.constraints.a_dot_qd.as_slice())?;
        // => sliding sites with kinetic friction
        crate::friction::collect(model, self, qd)?;
        // => which joints are free and massless, and the locked ones: kept from the last
        // mode where what they depend on is the same (the common case: a mode's flow)
        let key = FreeJointsKey::of(model, mode);
        if key.is_some() && key == self.free_key && self.locked == self.free_locked {
            return Ok(());
        }
        self.free_key = None;
        match key {
            Some(key) => key.split(&mut self.free_joints, &mut self.dynamic_coords),
            None => {
                free_massless_joints(model, mode, &mut self.free_joints, &mut self.dynamic_coords)
            }
        }
        // => locked joints prescribed as well
        for &j in &self.locked {
            if let Some(p) = self.dynamic_coords.iter().position(|&d| d == j) {
                if !model.distal_massless(j) {
                    return Err(crate::CoreError::InvalidMode {
                        reason: format!("joint {j} moves a massive link: it cannot be locked"),
                    });
                }
                self.dynamic_coords.remove(p);
                let at = self.free_joints.partition_point(|&f| f < j);
                self.free_joints.insert(at, j);
            }
        }
        self.free_key = key;
        self.free_locked.clone_from(&self.locked);
        Ok(())
    }
}

/// The joints of `mode` that are free massless joints (their whole distal chain massless,
/// no active contact on it; thesis 5.1.1) into `free`, and the coordinates kept in the KKT
/// system — every other joint, then `x, z, φ` — into `dynamic`, both ascending. A function
/// of the model and the mode only.
pub fn free_massless_joints(
    model: &Model,
    mode: ContactMode,
    free: &mut Vec<usize>,
    dynamic: &mut Vec<usize>,
) {
    if let Some(key) = FreeJointsKey::of(model, mode) {
        return key.split(free, dynamic);
    }
    free.clear();
    dynamic.clear();
    for j in 0..model.n_joints() {
        let distal = model.distal(j);
        let massless = model.distal_massless(j);
        let touched = mode
            .active()
            .any(|c| model.contacts[c].link.is_some_and(|l| distal.contains(&l)));
        if massless && !touched {
            free.push(j);
        } else {
            dynamic.push(j);
        }
    }
    dynamic.extend(model.n_joints()..model.nq());
}

/// Thesis (5.3)–(5.4): `q̈ = M†(Υ − C̄q̇ − N̄) − A†ᵀȦq̇`, `λ = A†(Υ − C̄q̇ − N̄) − ΛȦq̇`.
/// Results land in `data.qdd` and `data.lambda` (rows as in `data.constraints.rows`).
#[allow(clippy::too_many_arguments)]
pub fn forward_dynamics(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    qd: &[f64],
    tau: &[f64],
    free_joint_qdd: Option<&[f64]>,
) -> Result<()> {
    check_vector("tau", tau, model.n_joints())?;
    data.prepare(model, terrain, mode, q, qd)?;
    forward_dynamics_prepared(model, data, tau, free_joint_qdd)
}

/// [`forward_dynamics`] at the state of the last [`Data::prepare`] (which must have been at
/// the same `(mode, q, q̇)`): only the solve, for callers that needed the prepared stages
/// first (e.g. to learn which joints are free before prescribing their motion).
pub fn forward_dynamics_prepared(
    model: &Model,
    data: &mut Data,
    tau: &[f64],
    free_joint_qdd: Option<&[f64]>,
) -> Result<()> {
    check_vector("tau", tau, model.n_joints())?;
    if let Some(xf) = free_joint_qdd {
        check_vector("free_joint_qdd", xf, data.free_joints.len())?;
    }
    // (τ) => kinetic friction f^fr of the sliding sites
    crate::friction::resolve(model, data, tau)?;
    crate::friction::solve_dynamics(model, data, tau, free_joint_qdd)?;
    if data.damped_modes.is_some() {
        let mut lambda = std::mem::take(&mut data.lambda);
        crate::damped_slide::splice(data, &mut lambda, |d| d.lambda[1]);
        data.lambda = lambda;
    }
    check_result("q̈", data.qdd.as_slice())?;
    check_result("λ", data.lambda.as_slice())
}

/// Result of a plastic impact into a mode.
#[derive(Debug, Clone, PartialEq)]
pub struct Impact {
    /// Post-impact velocity `q̇⁺ = q̇⁻ − A†ᵀ A q̇⁻` (5.52).
    pub qd_plus: DVector<f64>,
    /// Contact impulse `P_λ = −Λ A q̇⁻` (5.10), same sign convention as `λ`.
    pub impulse: DVector<f64>,
}

/// Thesis (5.10)/(5.52): plastic impact into `mode` at `q` with incoming velocity `qd_minus`.
/// Free massless joints keep their velocity (they carry no momentum).
pub fn plastic_impact(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    qd_minus: &[f64],
) -> Result<Impact> {
    data.prepare(model, terrain, mode, q, qd_minus)?;
    plastic_impact_prepared(model, data, qd_minus)
}

/// [`plastic_impact`] at the state of the last [`Data::prepare`] (which must have been at
/// the same `(mode, q)`): only the solve, for callers that prepared the mode already (e.g.
/// to test that its KKT matrix is regular).
pub fn plastic_impact_prepared(model: &Model, data: &mut Data, qd_minus: &[f64]) -> Result<Impact> {
    check_vector("qd", qd_minus, model.nq())?;
    let nq = model.nq();
    let c = data.constraints.n_rows();
    // [M̄ Aᵀ; A 0][Δq̇; P] = [0; −A q̇⁻]
    let g = -(&data.constraints.a * DVector::from_column_slice(qd_minus));
    let (mut dx, mut p) = (DVector::zeros(nq), DVector::zeros(c));
    data.solve_prepared(|_, _| 0.0, |_, r| g[r], None, &mut dx, &mut p);
    let mut qd_plus = DVector::from_column_slice(qd_minus) + dx;
    if data.damped_modes.is_some() {
        // a damped slide takes no impulse: its chain's rates jump to the slide's
        crate::damped_slide::splice(data, &mut p, |_| 0.0);
        crate::damped_slide::impact_rates(model, data, &mut qd_plus)?;
    }
    check_result("q̇⁺", qd_plus.as_slice())?;
    check_result("P_λ", p.as_slice())?;
    Ok(Impact {
        qd_plus,
        impulse: p,
    })
}

/// Thesis (5.39): the pseudo-impulse `P_δ = A†(Υ − C̄q̇⁻ − N̄) δt` for an impact into `mode`,
/// with `Υ = tau` as given (the hybrid simulation passes the actuators' torque at the
/// post-impact velocity q̇⁺; see the thesis errata).
#[allow(clippy::too_many_arguments)]
pub fn pseudo_impulse(
    model: &Model,
    data: &mut Data,
    terrain: &dyn Terrain,
    mode: ContactMode,
    q: &[f64],
    qd_minus: &[f64],
    tau: &[f64],
    delta_t_s: f64,
) -> Result<DVector<f64>> {
    check_vector("tau", tau, model.n_joints())?;
    data.prepare(model, terrain, mode, q, qd_minus)?;
    pseudo_impulse_prepared(model, data, tau, delta_t_s)
}

/// [`pseudo_impulse`] at the state of the last [`Data::prepare`] (which must have been at
/// the same `(mode, q, q̇⁻)`): only the solve.
pub fn pseudo_impulse_prepared(
    model: &Model,
    data: &mut Data,
    tau: &[f64],
    delta_t_s: f64,
) -> Result<DVector<f64>> {
    check_vector("tau", tau, model.n_joints())?;
    // Υ is the applied force (actuators, springs, gravity); friction is a contact force
    data.friction.fill(0.0);
    let f = data.generalized_force(model, tau);
    let c = data.constraints.n_rows();
    let (mut x, mut y) = (DVector::zeros(model.nq()), DVector::zeros(c));
    data.solve_prepared(|_, a| f[a], |_, _| 0.0, None, &mut x, &mut y);
    if data.damped_modes.is_some() {
        crate::damped_slide::splice(data, &mut y, |_| 0.0);
    }
    let p = y * delta_t_s;
    check_result("P_δ", p.as_slice())?;
    Ok(p)
}

/// Kinetic energy `½ q̇ᵀ M̄ q̇` (4.24) at the state of the last `prepare`.
pub fn kinetic_energy(data: &Data, qd: &[f64]) -> f64 {
    let v = DVector::from_column_slice(qd);
    0.5 * v.dot(&(&data.m_bar * &v))
}

/// Potential energy `V = V_g + V_s`: gravity's (4.27) and the passive joint springs'
/// ([`crate::passive::potential_energy`]) at the configuration `q` of `kin`. The one
/// definition of `V` that the energy report and `Robot.energy` use: the springs' torques in
/// the flow ([`crate::passive::spring_torque`]) are its gradient, plus the dampers'.
pub fn potential_energy(model: &Model, kin: &crate::kinematics::Kinematics, q: &[f64]) -> f64 {
    crate::inertia::potential_energy(model, kin) + crate::passive::potential_energy(model, q)
}

/// Kinetic (4.24) and potential energy `(T, V)` ([`potential_energy`]: gravity and springs)
/// of `model` at `(q, q̇)`: the checked entry point (typed errors for bad or overflowing
/// inputs, never inf or NaN). Only `M̄` and the poses are needed, so the flight mode is
/// prepared and its KKT matrix (singular with free massless legs) does not matter.
pub fn energy(model: &Model, data: &mut Data, q: &[f64], qd: &[f64]) -> Result<(f64, f64)> {
    data.prepare_geometry(model, &crate::FlatGround, ContactMode::FLIGHT, q, qd)?;
    let t = kinetic_energy(data, qd);
    let v = potential_energy(model, &data.kin, q);
    check_result("T", &[t])?;
    check_result("V", &[v])?;
    Ok((t, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::contact::ContactKind;
    use crate::RobotDescription;

    /// A body with a massive two-link leg, a massless two-link leg and a nose, each with a
    /// sticking contact (the leg's at its toe).
    fn two_legs_and_a_nose() -> Model {
        RobotDescription::from_toml_str(
            r#"
            name = "two_legs"
            [body]
            mass_kg = 2.0
            inertia_kg_m2 = 0.02
            [[legs]]
            name = "a"
            hip_m = [0.2, 0.0]
            links = [{ length_m = 0.12, mass_kg = 0.2, inertia_kg_m2 = 2e-4 },
                     { length_m = 0.1, mass_kg = 0.1, inertia_kg_m2 = 1e-4 }]
            [[legs]]
            name = "b"
            hip_m = [-0.2, 0.0]
            links = [{ length_m = 0.12 }, { length_m = 0.1 }]
            [[contacts]]
            name = "a_toe"
            leg = "a"
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sticking", mu = 0.8 }
            [[contacts]]
            name = "b_toe"
            leg = "b"
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sticking", mu = 0.8 }
            [[contacts]]
            name = "nose"
            shape = { kind = "point", position_m = [0.3, 0.05] }
            friction = { kind = "sticking", mu = 0.8 }
        "#,
        )
        .unwrap()
        .build()
        .unwrap()
    }

    /// [`Data::prepare_at_state`] after a preparation at the same state in another mode
    /// gives what [`Data::prepare`] gives on a fresh workspace, bit for bit — `q̈` and `λ`,
    /// or the same error — for every mode of sticking and sliding contacts on a massive leg,
    /// a massless leg and the body, at random states.
    #[test]
    fn prepare_at_state_matches_a_fresh_prepare_bit_for_bit() {
        use crate::contact::FlatGround;
        use rand::{Rng, SeedableRng};
        let model = two_legs_and_a_nose();
        let (nq, nc) = (model.nq(), model.n_contacts());
        let tau = vec![0.3; model.n_joints()];
        let modes: Vec<ContactMode> = (0..3u32.pow(nc as u32))
            .map(|code| {
                (0..nc).fold(ContactMode::FLIGHT, |m, k| {
                    match code / 3u32.pow(k as u32) % 3 {
                        1 => m.with(k, ContactKind::Stick),
                        2 => m.with(k, ContactKind::Slide),
                        _ => m,
                    }
                })
            })
            .collect();
        let solve = |data: &mut Data, prepared: Result<()>| {
            prepared.and_then(|()| {
                let free = vec![0.0; data.free_joints.len()];
                forward_dynamics_prepared(&model, data, &tau, Some(&free))?;
                let bits = |v: &DVector<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                Ok((bits(&data.qdd), bits(&data.lambda)))
            })
        };
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let mut shared = Data::new(&model);
        let mut solved = 0;
        for _ in 0..20 {
            let q: Vec<f64> = (0..nq).map(|_| rng.gen_range(-2.0..2.0)).collect();
            let qd: Vec<f64> = (0..nq).map(|_| rng.gen_range(-5.0..5.0)).collect();
            shared
                .prepare(&model, &FlatGround, ContactMode::FLIGHT, &q, &qd)
                .unwrap();
            for &mode in &modes {
                let mut fresh = Data::new(&model);
                let p = fresh.prepare(&model, &FlatGround, mode, &q, &qd);
                let expected = solve(&mut fresh, p);
                let p = shared.prepare_at_state(&model, &FlatGround, mode, &qd);
                let got = solve(&mut shared, p);
                assert_eq!(
                    format!("{got:?}"),
                    format!("{expected:?}"),
                    "{mode:?} at {q:?}"
                );
                solved += usize::from(expected.is_ok());
            }
        }
        // (most modes are regular at most states)
        assert!(solved > 10 * modes.len(), "{solved}");
    }

    /// The free and locked joints a workspace keeps from one preparation to the next are a
    /// fresh workspace's — its joint lists, `q̈` and `λ` bit for bit, or the same error —
    /// as the locked joints change at one mode, as the mode changes, and as the model
    /// changes under the same workspace (a massless leg's link gains mass, or armature).
    #[test]
    fn kept_free_joints_are_a_fresh_workspaces() {
        use crate::contact::FlatGround;
        let model = two_legs_and_a_nose();
        let mut heavy = model.clone();
        heavy.joints[3].mass_kg = 0.05;
        let mut turning = model.clone();
        turning.joints[2].armature_kg_m2 = 1e-3;
        let nq = model.nq();
        let q: Vec<f64> = (0..nq).map(|i| 0.3 * (i as f64 + 1.0).sin()).collect();
        let qd: Vec<f64> = (0..nq).map(|i| 0.7 * (i as f64 + 2.0).cos()).collect();
        let tau = vec![0.2; model.n_joints()];
        let a = ContactMode::FLIGHT.with(0, ContactKind::Stick);
        let ab = a.with(1, ContactKind::Stick);
        let run = |data: &mut Data, model: &Model, mode: ContactMode, locked: &[usize]| {
            data.locked = locked.to_vec();
            let solved = data
                .prepare(model, &FlatGround, mode, &q, &qd)
                .and_then(|()| {
                    let free = vec![0.1; data.free_joints.len()];
                    forward_dynamics_prepared(model, data, &tau, Some(&free))?;
                    let bits = |v: &DVector<f64>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    Ok((bits(&data.qdd), bits(&data.lambda)))
                });
            format!(
                "{solved:?} {:?} {:?}",
                data.free_joints, data.dynamic_coords
            )
        };
        let steps: [(&Model, ContactMode, &[usize]); 9] = [
            (&model, a, &[]),
            (&model, a, &[]),
            (&model, ab, &[]),
            (&model, ab, &[2]),
            (&model, ab, &[2]),
            (&model, ab, &[]),
            (&heavy, ab, &[]),
            (&heavy, a, &[]),
            (&turning, a, &[]),
        ];
        let mut shared = Data::new(&model);
        let mut outcomes = Vec::new();
        for (model, mode, locked) in steps {
            let expected = run(&mut Data::new(model), model, mode, locked);
            assert_eq!(
                run(&mut shared, model, mode, locked),
                expected,
                "{mode:?} {locked:?}"
            );
            outcomes.push(expected);
        }
        // (the steps do move the free joints: b's leg free in flight, not when its link has
        // mass; locked or not in contact)
        outcomes.dedup();
        assert!(outcomes.len() >= 5, "{outcomes:#?}");
    }

    /// [`free_massless_joints`]' bit sets give the joints of its definition (thesis 5.1.1:
    /// the whole distal chain massless — no mass, inertia or armature — and no active contact
    /// on it), for every mode of a robot with a massless two-link leg, a leg whose distal link
    /// has mass, one whose joint has armature only, and a one-link leg, with contacts on
    /// proximal and distal links and on the body.
    #[test]
    fn free_massless_joints_follow_their_definition() {
        let model = RobotDescription::from_toml_str(
            r#"
            name = "mixed"
            [body]
            mass_kg = 2.0
            inertia_kg_m2 = 0.02
            [[legs]]
            name = "a"
            hip_m = [0.2, 0.0]
            links = [{ length_m = 0.1 }, { length_m = 0.1 }]
            [[legs]]
            name = "b"
            hip_m = [0.0, 0.0]
            links = [{ length_m = 0.1 }, { length_m = 0.1, mass_kg = 0.1 }]
            [[legs]]
            name = "c"
            hip_m = [-0.2, 0.0]
            links = [{ length_m = 0.1, armature_kg_m2 = 0.01 }, { length_m = 0.1 }]
            [[legs]]
            name = "d"
            hip_m = [-0.3, 0.0]
            links = [{ length_m = 0.1 }]
            [[contacts]]
            name = "a_toe"
            leg = "a"
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sticking", mu = 1.0 }
            [[contacts]]
            name = "a_knee"
            leg = "a"
            link = 0
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sliding" }
            [[contacts]]
            name = "b_toe"
            leg = "b"
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sliding" }
            [[contacts]]
            name = "c_toe"
            leg = "c"
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sliding" }
            [[contacts]]
            name = "d_toe"
            leg = "d"
            shape = { kind = "point", position_m = [0.0, 0.1] }
            friction = { kind = "sliding" }
            [[contacts]]
            name = "nose"
            shape = { kind = "point", position_m = [0.3, 0.0] }
            friction = { kind = "sliding" }
            "#,
        )
        .unwrap()
        .build()
        .unwrap();
        let nc = model.n_contacts();
        let (mut free, mut dynamic) = (Vec::new(), Vec::new());
        let mut n_free = 0;
        for bits in 0u32..1 << nc {
            let mode = (0..nc)
                .filter(|k| bits >> k & 1 == 1)
                .fold(ContactMode::FLIGHT, |m, k| m.with(k, ContactKind::Slide));
            free_massless_joints(&model, mode, &mut free, &mut dynamic);
            let expected: Vec<usize> = (0..model.n_joints())
                .filter(|&j| {
                    let chain = model.distal(j);
                    chain.clone().all(|i| {
                        let joint = &model.joints[i];
                        joint.mass_kg == 0.0
                            && joint.inertia_kg_m2 == 0.0
                            && joint.armature_kg_m2 == 0.0
                    }) && !mode
                        .active()
                        .any(|c| model.contacts[c].link.is_some_and(|l| chain.contains(&l)))
                })
                .collect();
            assert_eq!(free, expected, "mode bits {bits:b}");
            let mut all: Vec<usize> = free.iter().chain(&dynamic).copied().collect();
            all.sort_unstable();
            assert_eq!(all, (0..model.nq()).collect::<Vec<_>>());
            n_free += free.len();
        }
        // (a sanity check of the robot: some joints are free in some modes, not all in all)
        assert!(n_free > 0 && n_free < (1 << nc) * model.n_joints());
    }
}
