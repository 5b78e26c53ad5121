//! Engine parameters that stand behind a preset's named ones on any robot (the weighted sums
//! of [`crate::sensitivity`]): the armature of every joint that has one, a contact's friction
//! coefficient by the contact's name; and a run's start state moved off its scenario's, for
//! derivatives along start directions.
use crate::error::invalid;
use crate::{SimError, Simulation};
use selfmanip_core::model::Friction;
use selfmanip_core::tangent::BodyParameter;
use selfmanip_core::Model;
use selfmanip_hybrid::sensitivity::{FrictionCoefficient, Parameter};

/// `(∂/∂a_j, w)` for every joint `j` that has an armature (a compliant leg's knee has none).
pub fn armature_terms(model: &Model, w: f64) -> Vec<(Parameter, f64)> {
    (0..model.joints.len())
        .filter(|&j| model.joints[j].armature_kg_m2 > 0.0)
        .map(|j| (Parameter::Body(BodyParameter::Armature(j)), w))
        .collect()
}

/// The friction parameter of the contact named `name`: its static `μ`, and the kinetic one
/// with it where it slides with Coulomb friction (`coulomb`). The reason why not, for a
/// contact that is not there or whose `μ` is infinite or absent.
pub fn contact_friction(model: &Model, name: &str, coulomb: bool) -> Result<Parameter, String> {
    let contact = (model.contacts.iter().position(|c| c.name == name))
        .ok_or_else(|| format!("there is no contact `{name}`"))?;
    match model.contacts[contact].friction {
        Friction::Sticking { mu } if mu.is_finite() => Ok(Parameter::Friction {
            contact,
            coefficient: match coulomb {
                true => FrictionCoefficient::Both,
                false => FrictionCoefficient::Static,
            },
        }),
        _ => Err(format!(
            "the friction coefficient of `{name}` is infinite or absent"
        )),
    }
}

/// Moves the start state of `sim` by `dx` (`2nq` entries over `(q, q̇)`; errors name the
/// field `start_offset`).
pub fn offset_start(sim: &mut Simulation, dx: &[f64]) -> Result<(), SimError> {
    let nq = sim.q0.len();
    if dx.len() != 2 * nq {
        let reason = format!("expected {} entries, got {}", 2 * nq, dx.len());
        return Err(invalid("start_offset", reason));
    }
    for i in 0..nq {
        sim.q0[i] += dx[i];
        sim.qd0[i] += dx[nq + i];
    }
    Ok(())
}
