//! Coulomb friction at RHex's body ends (`RhexParams::mu_body`), off by default (section
//! C.3, Assumption 5.9): a bad coefficient is a typed error naming the field; with it the
//! description carries the coefficient on both ends and nothing else (a second route to the
//! model: the default description with only the ends' friction changed); and a leap whose
//! body ends leave the ground before anything slides — (+,+) at t2 = 0, where the two legs'
//! touchdown lifts both ends (`1010 → 0101`) — is the default leap to the last bit, because
//! a sticking end at rest under a body at rest carries no tangential force (conservation: the
//! friction does no work, and the flow is the same).
mod common;
use common::default_leap_and;
use rhex_model::leap::leap_params;
use rhex_model::{RhexError, RhexParams};
use selfmanip_core::description::FrictionDescription;

#[test]
fn bad_body_friction_is_a_typed_error_naming_mu_body() {
    for mu in [-0.1, f64::NAN, f64::INFINITY] {
        let params = RhexParams {
            mu_body: Some(mu),
            ..leap_params()
        };
        match params.validate() {
            Err(RhexError::InvalidValue { field, .. }) => assert_eq!(field, "mu_body"),
            other => panic!("μ {mu}: {other:?}"),
        }
    }
}

#[test]
fn body_friction_changes_only_the_body_ends_of_the_description() {
    let base = leap_params();
    let with = RhexParams {
        mu_body: Some(0.3),
        ..base.clone()
    };
    let (d0, d1) = (base.description(), with.description());
    assert_eq!(d0.contacts.len(), d1.contacts.len());
    for (c0, c1) in d0.contacts.iter().zip(&d1.contacts) {
        if c0.leg.is_none() {
            assert_eq!(c0.friction, FrictionDescription::Sliding);
            assert_eq!(
                c1.friction,
                FrictionDescription::Sticking {
                    mu: Some(0.3),
                    mu_kinetic: Some(0.3)
                }
            );
        } else {
            assert_eq!(c0, c1);
        }
    }
    assert_eq!(d0.legs, d1.legs);
    // and the model builds: kinetic friction at a body site is accepted
    with.description().build().unwrap();
}

#[test]
fn leap_whose_body_ends_lift_before_sliding_is_the_default_one() {
    let (r0, r1) = default_leap_and(|p| p.mu_body = Some(0.3));
    assert_eq!(r0.word, r1.word);
    assert_eq!(r0.word[..2], ["1010".to_string(), "0101".to_string()]);
    let (a0, a1) = (r0.apex.unwrap(), r1.apex.unwrap());
    assert_eq!(a0.z_m.to_bits(), a1.z_m.to_bits());
    assert_eq!(a0.phi_rad.to_bits(), a1.phi_rad.to_bits());
}
