//! The RHex model object and its contact-mode labels.
//!
//! Labels follow chapter 3: one character per contact site, front half first —
//! `FB FL RB RL` for two leg pairs (`"0101"` = both legs down, `"1010"` = sitting on the
//! body), `FB FL ML RB RL` for three. `FL` is the front-most pair present and `RL` the
//! rear-most. A character is `0` (no contact), `1` (contact with the site's own friction:
//! toes stick, the body slides) or `s` (a toe in contact but sliding, section 5.1.5).
use crate::params::{LegPair, RhexParams};
use crate::RhexError;
use selfmanip_core::{ContactKind, ContactMode, Model};
use selfmanip_sim::{ContactLabels, SimError};

/// An RHex instance: its parameters and the generic core model built from them.
#[derive(Debug, Clone)]
pub struct Rhex {
    pub params: RhexParams,
    pub model: Model,
    /// Contact index of each label character, in label order.
    label_sites: Vec<usize>,
}

impl Rhex {
    pub fn new(params: RhexParams) -> Result<Self, RhexError> {
        params.validate()?;
        let model = params.description().build()?;
        let pairs = params.ordered_pairs();
        let idx = |name: &str| model.contact_index(name).expect("built by params");
        let leg = |p: LegPair| idx(&format!("{}_leg", p.name()));
        let mut label_sites = vec![idx("front_body"), leg(pairs[0])];
        if pairs.len() == 3 {
            label_sites.push(leg(pairs[1]));
        }
        label_sites.push(idx("rear_body"));
        if pairs.len() > 1 {
            label_sites.push(leg(*pairs.last().expect("non-empty")));
        }
        Ok(Rhex {
            params,
            model,
            label_sites,
        })
    }

    /// The chapter-4 default: two half-circle massless legs, Table 4.2.
    pub fn chapter4() -> Self {
        Rhex::new(RhexParams::default()).expect("Table 4.2 is valid")
    }

    /// Contact index of label character `i` (`FB FL RB RL`: 0 = front body, 1 = front leg, …).
    pub fn site(&self, i: usize) -> usize {
        self.label_sites[i]
    }

    /// Number of characters in a mode label.
    pub fn label_len(&self) -> usize {
        self.label_sites.len()
    }

    /// Parses a label such as `"0101"` into a contact mode (the generic
    /// [`ContactLabels::parse`] in this order; `s` only on a leg, the body always slides).
    pub fn mode(&self, label: &str) -> Result<ContactMode, RhexError> {
        let err = |reason: String| RhexError::ModeLabel {
            label: label.to_string(),
            reason,
        };
        let n = label.chars().count();
        if n != self.label_sites.len() {
            let (k, legend) = (self.label_sites.len(), self.label_legend());
            return Err(err(format!("expected {k} characters ({legend}), got {n}")));
        }
        if label
            .chars()
            .zip(&self.label_sites)
            .any(|(c, &k)| c == 's' && self.on_body(k))
        {
            return Err(err(
                "`s` (sliding) only applies to legs; the body always slides".into(),
            ));
        }
        let labels = ContactLabels::from_indices(&self.model, self.label_sites.clone());
        labels.parse(&self.model, label).map_err(|e| match e {
            SimError::InvalidValue { reason, .. } => err(reason),
            e => e.into(),
        })
    }

    /// The label of a mode (inverse of [`Self::mode`]).
    pub fn label(&self, mode: ContactMode) -> String {
        self.label_sites
            .iter()
            .map(|&site| match mode.kind(site) {
                None => '0',
                Some(ContactKind::Slide) if !self.on_body(site) => 's',
                Some(_) => '1',
            })
            .collect()
    }

    fn on_body(&self, site: usize) -> bool {
        self.model.contacts[site].link.is_none()
    }

    /// `"FB FL RB RL"` (or the three-pair legend).
    pub fn label_legend(&self) -> String {
        let names: Vec<&str> = match self.label_sites.len() {
            5 => vec!["FB", "FL", "ML", "RB", "RL"],
            4 => vec!["FB", "FL", "RB", "RL"],
            _ => vec!["FB", "L", "RB"],
        };
        names.join(" ")
    }

    /// All labels with `0`/`1` characters (every subset of contact sites).
    pub fn all_labels(&self) -> Vec<String> {
        let k = self.label_sites.len();
        (0..1u32 << k)
            .map(|bits| {
                (0..k)
                    .map(|i| {
                        if bits >> (k - 1 - i) & 1 == 1 {
                            '1'
                        } else {
                            '0'
                        }
                    })
                    .collect()
            })
            .collect()
    }
}
