//! RHex parameters (thesis Table 4.2) and the generic robot description they build.
//!
//! The planar model (section 4.2.1): hips at `+ℓ₁` (front), `0` (middle) and `−ℓ₂` (rear)
//! on the body's x axis; one joint per leg with the thesis's clockwise θ (joint axis `−y`),
//! so that `θ = 0` points the leg straight down the body's `+z`. A half-circle leg is an arc
//! of radius `ρ/2` about the middle of the hip–toe line, rounded on the side where
//! `−π < θ − φ < 0` (4.2.2); a stick leg ends in a point toe. The body has rounded ends of
//! radius `ρ_b` about the front and rear hips, which slide without friction (C.3). Toes
//! stick (C.4) unless a finite `μ` lets them slip (section 5.1.5).
use selfmanip_core::description::{
    BodyDescription, ContactDescription, FrictionDescription, JointAxis, LegDescription,
    LinkDescription, RobotDescription, ShapeDescription,
};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Shape of RHex's legs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LegShape {
    HalfCircle,
    Stick,
}

/// How a toe that has slipped slides (section 5.1.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ToeSliding {
    /// Coulomb's law with one coefficient: a sliding toe's force stays on the edge of its
    /// friction cone (`μ_k = μ`), so the ground force is continuous through a slip.
    #[default]
    Coulomb,
    /// The thesis's Assumption 5.9: a sliding toe carries no tangential force (`μ_k = 0`).
    Frictionless,
}

/// A hip position along the body.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, PartialOrd, Ord)]
#[serde(rename_all = "snake_case")]
pub enum LegPair {
    Front,
    Middle,
    Rear,
}

impl LegPair {
    pub fn name(self) -> &'static str {
        match self {
            LegPair::Front => "front",
            LegPair::Middle => "middle",
            LegPair::Rear => "rear",
        }
    }
}

/// Table 4.2 with the thesis's symbols (planar legs = contralateral pairs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct RhexParams {
    pub m_b: f64,
    pub I_b: f64,
    pub m_l: f64,
    pub I_l: f64,
    pub l1: f64,
    pub l2: f64,
    pub rho1: f64,
    pub rho2: f64,
    pub rho_b: f64,
    pub tau_s: f64,
    pub g: f64,
    pub leg_shape: LegShape,
    pub pairs: Vec<LegPair>,
    /// Toe friction coefficients (front-most, middle, rear-most pair); `None` never slips.
    #[serde(default)]
    pub mu_front: Option<f64>,
    #[serde(default)]
    pub mu_middle: Option<f64>,
    #[serde(default)]
    pub mu_rear: Option<f64>,
    /// How a toe slides once it has slipped.
    #[serde(default)]
    pub toe_sliding: ToeSliding,
    /// Coulomb friction of the body ends (static = kinetic). `None` (the default) or
    /// `Some(0.0)`: they slide without friction (Assumption 5.9, section C.3). A leap starts
    /// with the front end sticking and the rear one sliding (both sticking is indeterminate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mu_body: Option<f64>,
    /// Armature of every leg joint (kg m², [`selfmanip_core::model::Joint::armature_kg_m2`]).
    /// `None` (the default): a leap gives legs that carry their rotors
    /// ([`Self::legs_carry_rotors`]) the actuator's `n J G²`
    /// ([`crate::leap::rotor_reflected_inertia`]), others none; [`crate::Rhex::new`] alone
    /// gives none. `Some(a)`: `a` on every leg joint (`Some(0.0)`: bare legs).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leg_armature_kg_m2: Option<f64>,
    /// Whether a leap's legs carry their motors' rotors as joint armature (following the gear
    /// ratio). `None` (the default): massive legs do, massless legs do not (Assumption C.6;
    /// `docs/decisions/2026-11-24-massless-legs-stay-default.md`). Exclusive with
    /// [`Self::leg_armature_kg_m2`].
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub leg_rotors: Option<bool>,
}

/// The shipped Table 4.2 file.
pub const TABLE_4_2_TOML: &str = include_str!("../data/table_4_2.toml");

/// The shipped Table 4.2, parsed once per process ([`RhexParams::default`] clones it).
static TABLE_4_2: std::sync::OnceLock<RhexParams> = std::sync::OnceLock::new();

impl Default for RhexParams {
    fn default() -> Self {
        TABLE_4_2
            .get_or_init(|| toml::from_str(TABLE_4_2_TOML).expect("the shipped Table 4.2 parses"))
            .clone()
    }
}

impl RhexParams {
    pub fn from_toml_str(s: &str) -> Result<Self, crate::RhexError> {
        toml::from_str(s).map_err(|e| crate::RhexError::Unreadable {
            field: "toml".into(),
            reason: e.to_string(),
        })
    }

    /// Checks every field (names in errors are the Table 4.2 symbols).
    pub fn validate(&self) -> Result<(), crate::RhexError> {
        let bad = |f: &str, r: &str| Err(crate::RhexError::invalid(f, r));
        let fields = [
            ("m_b", self.m_b),
            ("I_b", self.I_b),
            ("m_l", self.m_l),
            ("I_l", self.I_l),
            ("l1", self.l1),
            ("l2", self.l2),
            ("rho1", self.rho1),
            ("rho2", self.rho2),
            ("rho_b", self.rho_b),
            ("tau_s", self.tau_s),
            ("g", self.g),
        ];
        for (name, v) in fields {
            if !v.is_finite() {
                return bad(name, "must be finite");
            }
            if v < 0.0 {
                return bad(name, "must be non-negative");
            }
        }
        for (name, v) in [("m_b", self.m_b), ("rho1", self.rho1), ("rho2", self.rho2)] {
            if v == 0.0 {
                return bad(name, "must be positive");
            }
        }
        if self.pairs.is_empty() {
            return bad("pairs", "at least one leg pair is needed");
        }
        let mut sorted = self.pairs.clone();
        sorted.sort();
        sorted.dedup();
        if sorted.len() != self.pairs.len() {
            return bad("pairs", "duplicate leg pair");
        }
        for (name, mu) in [
            ("mu_front", self.mu_front),
            ("mu_middle", self.mu_middle),
            ("mu_rear", self.mu_rear),
        ] {
            if mu.is_some_and(|m| m.is_nan() || m < 0.0) {
                return bad(name, "must be non-negative");
            }
        }
        if self.leg_rotors.is_some() && self.leg_armature_kg_m2.is_some() {
            return bad(
                "leg_rotors",
                "set either leg_rotors (the actuator's rotors) or leg_armature_kg_m2 (by hand), \
                 not both",
            );
        }
        match self.leg_armature_kg_m2 {
            Some(a) if !a.is_finite() => return bad("leg_armature_kg_m2", "must be finite"),
            Some(a) if a < 0.0 => return bad("leg_armature_kg_m2", "must be non-negative"),
            _ => {}
        }
        // also the kinetic coefficient: finite
        if self.mu_body.is_some_and(|m| !(m.is_finite() && m >= 0.0)) {
            return bad("mu_body", "must be finite and non-negative");
        }
        Ok(())
    }

    /// Whether the legs have mass or inertia of their own (Table 4.2's pair; the default
    /// model's legs are massless, Assumption C.6).
    pub fn massive_legs(&self) -> bool {
        self.m_l != 0.0 || self.I_l != 0.0
    }

    /// `self` with Table 4.2's legs: one planar leg is a contralateral pair, twice the table's
    /// single leg (mass 2 × 0.063 kg, inertia about its centre of mass 2 × 0.00046 kg m²).
    /// The default model's legs are massless (Assumption C.6).
    pub fn with_table_4_2_legs(self) -> Self {
        RhexParams {
            m_l: 2.0 * 0.063,
            I_l: 2.0 * 0.00046,
            ..self
        }
    }

    /// Whether a leap gives the legs their motors' rotors as armature
    /// ([`Self::leg_rotors`]; by default, massive legs).
    pub fn legs_carry_rotors(&self) -> bool {
        self.leg_rotors.unwrap_or(self.massive_legs())
    }

    /// Leg pairs in body order (front to rear).
    pub fn ordered_pairs(&self) -> Vec<LegPair> {
        let mut p = self.pairs.clone();
        p.sort();
        p
    }

    /// Leg length of a pair (the middle leg uses the front length).
    pub fn rho(&self, pair: LegPair) -> f64 {
        match pair {
            LegPair::Front | LegPair::Middle => self.rho1,
            LegPair::Rear => self.rho2,
        }
    }

    /// Hip position along the body x axis.
    pub fn hip_x(&self, pair: LegPair) -> f64 {
        match pair {
            LegPair::Front => self.l1,
            LegPair::Middle => 0.0,
            LegPair::Rear => -self.l2,
        }
    }

    fn mu(&self, pair: LegPair) -> Option<f64> {
        match pair {
            LegPair::Front => self.mu_front,
            LegPair::Middle => self.mu_middle,
            LegPair::Rear => self.mu_rear,
        }
    }

    /// The generic description: legs in body order, contacts `<pair>_leg` in body order,
    /// then `front_body`, `rear_body` (chapter 4's k = 1, 2, 3, 4 for two pairs).
    pub fn description(&self) -> RobotDescription {
        let pairs = self.ordered_pairs();
        let legs = pairs
            .iter()
            .map(|&p| LegDescription {
                name: p.name().into(),
                hip_m: [self.hip_x(p), 0.0],
                links: vec![LinkDescription {
                    length_m: self.rho(p),
                    mass_kg: self.m_l,
                    inertia_kg_m2: self.I_l,
                    com_m: Some([0.0, 0.5 * self.rho(p)]),
                    axis: JointAxis::MinusY,
                    spring: None,
                    armature_kg_m2: self.leg_armature_kg_m2.unwrap_or(0.0),
                    collision: Vec::new(),
                }],
            })
            .collect();
        let mut contacts: Vec<ContactDescription> = pairs
            .iter()
            .map(|&p| {
                let rho = self.rho(p);
                let shape = match self.leg_shape {
                    LegShape::Stick => ShapeDescription::Point {
                        position_m: [0.0, rho],
                    },
                    LegShape::HalfCircle => ShapeDescription::Arc {
                        center_m: [0.0, 0.5 * rho],
                        radius_m: 0.5 * rho,
                        normal_range_rad: [-PI, 0.0],
                    },
                };
                ContactDescription {
                    name: format!("{}_leg", p.name()),
                    leg: Some(p.name().into()),
                    link: None,
                    shape,
                    friction: FrictionDescription::Sticking {
                        mu: self.mu(p),
                        mu_kinetic: match self.toe_sliding {
                            ToeSliding::Coulomb => self.mu(p),
                            ToeSliding::Frictionless => Some(0.0),
                        },
                    },
                }
            })
            .collect();
        for (name, x) in [("front_body", self.l1), ("rear_body", -self.l2)] {
            contacts.push(ContactDescription {
                name: name.into(),
                leg: None,
                link: None,
                shape: ShapeDescription::Circle {
                    center_m: [x, 0.0],
                    radius_m: self.rho_b,
                },
                // μ = 0 is the frictionless default, its limit (a sticking end that can
                // hold no tangential force would only make the start indeterminate)
                friction: match self.mu_body {
                    None | Some(0.0) => FrictionDescription::Sliding,
                    Some(mu) => FrictionDescription::Sticking {
                        mu: Some(mu),
                        mu_kinetic: Some(mu),
                    },
                },
            });
        }
        RobotDescription {
            name: format!("RHex ({} pairs, {:?} legs)", pairs.len(), self.leg_shape),
            gravity_m_s2: self.g,
            body: BodyDescription {
                mass_kg: self.m_b,
                inertia_kg_m2: self.I_b,
                collision: Vec::new(),
            },
            legs,
            contacts,
        }
    }
}
