//! Names: of joints (after their legs), of contact modes in a robot's own contact names,
//! and the contact-cell *word* of an execution (thesis chapter 3: the sequence of
//! ground-reaction-complex cells visited).
//!
//! A label has one character per contact, in an order the user chooses (default: the
//! description's): `0` (no contact), `1` (contact with the site's own friction: a sticking
//! site sticks, a frictionless one slides) or `s` (a site that could stick, sliding).
use crate::error::SimError;
use selfmanip_core::model::Friction;
use selfmanip_core::{ContactKind, ContactMode, Model};
use selfmanip_hybrid::Execution;

/// The order of a label's characters and what each can show.
#[derive(Debug, Clone, PartialEq)]
pub struct ContactLabels {
    /// Contact index of each character.
    order: Vec<usize>,
    names: Vec<String>,
    /// Whether the contact of each character can stick (so `s` means slipping).
    can_stick: Vec<bool>,
}

impl ContactLabels {
    /// Every contact of `model`, in the description's order.
    pub fn all(model: &Model) -> Self {
        Self::from_indices(model, (0..model.n_contacts()).collect())
    }

    /// The contacts at `order` (indices into `model.contacts`).
    pub fn from_indices(model: &Model, order: Vec<usize>) -> Self {
        let names = order
            .iter()
            .map(|&k| model.contacts[k].name.clone())
            .collect();
        let can_stick = order
            .iter()
            .map(|&k| matches!(model.contacts[k].friction, Friction::Sticking { .. }))
            .collect();
        ContactLabels {
            order,
            names,
            can_stick,
        }
    }

    /// The contacts named `names`, in that order (errors name `field[i]`).
    pub fn from_names(model: &Model, names: &[String], field: &str) -> Result<Self, SimError> {
        if names.is_empty() && model.n_contacts() > 0 {
            return Err(SimError::InvalidValue {
                field: field.to_string(),
                reason: "lists no contact: every label would be empty (omit it for all \
                         contacts, in the description's order)"
                    .into(),
            });
        }
        let mut order = Vec::with_capacity(names.len());
        for (i, n) in names.iter().enumerate() {
            let k = contact_by_name(model, n, &format!("{field}[{i}]"))?;
            if order.contains(&k) {
                return Err(SimError::InvalidValue {
                    field: format!("{field}[{i}]"),
                    reason: format!("contact `{n}` is listed twice"),
                });
            }
            order.push(k);
        }
        Ok(Self::from_indices(model, order))
    }

    /// The contact names of the characters, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The label of `mode` (contacts not in the order are not shown).
    pub fn label(&self, mode: ContactMode) -> String {
        self.order
            .iter()
            .zip(&self.can_stick)
            .map(|(&k, &stick)| match mode.kind(k) {
                None => '0',
                Some(ContactKind::Slide) if stick => 's',
                Some(_) => '1',
            })
            .collect()
    }

    /// The mode of a label (inverse of [`Self::label`] for the contacts shown).
    pub fn parse(&self, model: &Model, label: &str) -> Result<ContactMode, SimError> {
        let bad = |reason: String| SimError::InvalidValue {
            field: format!("mode `{label}`"),
            reason,
        };
        let chars: Vec<char> = label.chars().collect();
        if chars.len() != self.order.len() {
            return Err(bad(format!(
                "expected {} characters ({}), got {}",
                self.order.len(),
                self.names.join(" "),
                chars.len()
            )));
        }
        let mut mode = ContactMode::FLIGHT;
        for ((&ch, &k), &stick) in chars.iter().zip(&self.order).zip(&self.can_stick) {
            mode = match ch {
                '0' => mode,
                '1' => mode.union(ContactMode::with_defaults(model, &[k])?),
                's' if stick => mode.with(k, ContactKind::Slide),
                's' => {
                    return Err(bad(format!(
                        "contact `{}` cannot stick, so it cannot slip",
                        model.contacts[k].name
                    )))
                }
                other => return Err(bad(format!("character `{other}` is not 0, 1 or s"))),
            };
        }
        Ok(mode)
    }
}

/// The contact called `name`, or an error naming `field`.
pub fn contact_by_name(model: &Model, name: &str, field: &str) -> Result<usize, SimError> {
    model
        .contacts
        .iter()
        .position(|c| c.name == name)
        .ok_or_else(|| SimError::UnknownContact {
            field: field.into(),
            name: name.into(),
            known: contact_names(model),
        })
}

pub(crate) fn contact_names(model: &Model) -> String {
    model
        .contacts
        .iter()
        .map(|c| c.name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// The contact-cell word of `exec`: the label of each segment's mode (`s` shown as `1` when
/// `sliding_as_contact`), repeats merged, and segments no longer than `min_duration_s`
/// skipped (except the first and the last).
pub fn contact_word(
    exec: &Execution,
    labels: &ContactLabels,
    min_duration_s: f64,
    sliding_as_contact: bool,
) -> Vec<String> {
    let mut word: Vec<String> = Vec::new();
    for (n, seg) in exec.segments.iter().enumerate() {
        let last = n + 1 == exec.segments.len();
        if seg.t1 - seg.t0 <= min_duration_s && n > 0 && !last {
            continue;
        }
        let mut cell = labels.label(seg.mode);
        if sliding_as_contact {
            cell = cell.replace('s', "1");
        }
        if word.last() != Some(&cell) {
            word.push(cell);
        }
    }
    word
}

/// The name of joint `j`: its leg's name for a one-link leg, else `leg[k]`.
pub fn joint_name(model: &Model, j: usize) -> String {
    let joint = &model.joints[j];
    let leg = &model.legs[joint.leg];
    if leg.n_links == 1 {
        leg.name.clone()
    } else {
        format!("{}[{}]", leg.name, joint.index_in_leg)
    }
}

/// The joint called `name` (`leg` for a one-link leg, `leg[k]`).
pub fn joint_index(model: &Model, name: &str) -> Option<usize> {
    (0..model.n_joints()).find(|&j| {
        joint_name(model, j) == name || {
            let joint = &model.joints[j];
            format!("{}[{}]", model.legs[joint.leg].name, joint.index_in_leg) == name
        }
    })
}

/// The contacts carried by joint `j`'s link or the links beyond it, as a bit set.
pub fn joint_contacts(model: &Model, j: usize) -> u32 {
    let distal = model.distal(j);
    model
        .contacts
        .iter()
        .enumerate()
        .filter(|(_, c)| c.link.is_some_and(|l| distal.contains(&l)))
        .fold(0, |m, (k, _)| m | 1 << k)
}
