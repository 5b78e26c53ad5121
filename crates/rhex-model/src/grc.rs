//! The ground reaction complex (GRC) of thesis chapter 3 as data.
//!
//! A **cell** is a set of ground contacts, four bits in the order `FB FL RB RL` (front body,
//! front leg, rear body, rear leg): `I_1010` sits, `I_0101` stands on both legs, `I_0000`
//! flies. The **Hasse diagram** of the 16 cells (Fig. 3.2) has 64 directed edges, sorted into
//! categories ([`TransitionCategory`], section 3.1.3); the 18 *allowable* ones (Fig. 3.3) make
//! the **leap grammar**, every path from `I_1010` to `I_0000`. The six **leap words**
//! (3.2)–(3.7) are those paths without zero-time cells (the 0-DOF cells, and under saturated
//! pushing `I_0011`/`I_1100`). Fig. 3.3 is reconstructed as the union of the leap words with
//! their zero-time cells restored ([`expand_zero_time`]: 18 edges over the 15 cells other than
//! `I_1111`, as the text states); `tests/grc.rs` checks [`categorize`] against it
//! (`docs/errata/ch3-leaping.md`: two misprints).
use crate::leap::Strategy;
use crate::RhexError;
use serde::Serialize;
use std::fmt;

/// Contact sites in label order.
pub const SITES: [&str; 4] = ["FB", "FL", "RB", "RL"];

/// One cell of the GRC: a set of active contacts (bit 3 = FB … bit 0 = RL).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Cell(u8);

impl Cell {
    pub const REST: Cell = Cell(0b1010);
    pub const FLIGHT: Cell = Cell(0b0000);
    pub const OVERCONSTRAINED: Cell = Cell(0b1111);

    /// From bits in label order (`0b1010` = `"1010"`).
    pub fn from_bits(bits: u8) -> Result<Cell, RhexError> {
        if bits > 0b1111 {
            return Err(RhexError::ModeLabel {
                label: format!("{bits:#b}"),
                reason: "a GRC cell has four bits".into(),
            });
        }
        Ok(Cell(bits))
    }

    /// From a label such as `"0101"`.
    pub fn from_label(label: &str) -> Result<Cell, RhexError> {
        let err = |reason: &str| RhexError::ModeLabel {
            label: label.into(),
            reason: reason.into(),
        };
        if label.chars().count() != 4 {
            return Err(err("a GRC cell label has four characters FB FL RB RL"));
        }
        let mut bits = 0u8;
        for ch in label.chars() {
            bits = (bits << 1)
                | match ch {
                    '0' => 0,
                    '1' => 1,
                    _ => return Err(err("characters must be 0 or 1")),
                };
        }
        Ok(Cell(bits))
    }

    pub fn bits(self) -> u8 {
        self.0
    }

    pub fn label(self) -> String {
        format!("{:04b}", self.0)
    }

    /// Whether site `i` (index into [`SITES`]) is in contact.
    pub fn has(self, site: usize) -> bool {
        self.0 >> (3 - site) & 1 == 1
    }

    /// Names of the active sites.
    pub fn contacts(self) -> Vec<&'static str> {
        (0..4).filter(|&i| self.has(i)).map(|i| SITES[i]).collect()
    }

    pub fn n_contacts(self) -> u32 {
        self.0.count_ones()
    }

    pub fn is_flight(self) -> bool {
        self.0 == 0
    }

    /// Degrees of freedom of the planar body in this cell (section 3.1.1): 3 in flight,
    /// 2 with one contact, 1 with two, 0 with three; `None` for the over-constrained `I_1111`.
    pub fn dof(self) -> Option<u32> {
        (self.n_contacts() < 4).then(|| 3 - self.n_contacts())
    }

    /// Completely constrained (0-DOF) cells, in which the robot generically spends no time.
    pub fn is_fully_constrained(self) -> bool {
        self.dof() == Some(0)
    }

    pub fn all() -> impl Iterator<Item = Cell> {
        (0..16u8).map(Cell)
    }
}

impl fmt::Display for Cell {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "I_{}", self.label())
    }
}

impl Serialize for Cell {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.label())
    }
}

/// The categories of section 3.1.3.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TransitionCategory {
    /// A leg touches down while the body end on its side rests on the ground: the hip height
    /// is fixed, so the guard is a function of the joint angle alone (`θ − θ_g`).
    ControlTriggered,
    /// A leg touches down while its side of the body is in the air: the guard also depends on
    /// height and pitch and may never be reached by moving the leg (e.g. `I_0000 → I_0100`).
    SometimesControlTriggered,
    /// A contact breaks because its force reaches zero (5.51): set by the dynamics and the
    /// initial conditions (takeoff, `I_0101 → I_0001`).
    StateTriggered,
    /// The body lifts off the ground with no leg acting (`I_1010 → I_1000`).
    Impossible,
    /// Possible but unwanted for leaping: a body end lands (`I_0000 → I_1000`).
    Undesirable,
    /// Into or out of the over-constrained `I_1111`, excluded from the complex's dynamics.
    Degenerate,
}

/// A directed edge of the Hasse diagram.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
pub struct Transition {
    pub from: Cell,
    pub to: Cell,
    /// The site added or removed (index into [`SITES`]).
    pub site: usize,
    /// `true` when the site touches down, `false` when it lifts off.
    pub touchdown: bool,
    pub category: TransitionCategory,
}

/// Category of the one-contact change `from → to` by the definitions of section 3.1.3.
/// `None` when the cells do not differ by exactly one contact.
pub fn categorize(from: Cell, to: Cell) -> Option<TransitionCategory> {
    let diff = from.0 ^ to.0;
    if diff.count_ones() != 1 {
        return None;
    }
    let site = 3 - diff.trailing_zeros() as usize;
    let touchdown = to.has(site);
    let is_leg = site % 2 == 1;
    let same_side_body = site - (site % 2); // FL→FB, RL→RB
    use TransitionCategory::*;
    Some(
        if from == Cell::OVERCONSTRAINED || to == Cell::OVERCONSTRAINED {
            Degenerate
        } else if touchdown && !is_leg {
            Undesirable
        } else if touchdown && from.has(same_side_body) {
            ControlTriggered
        } else if touchdown {
            SometimesControlTriggered
        } else if !is_leg && from == Cell::REST {
            // resting on both body ends with no leg down, nothing can lift either end
            Impossible
        } else {
            StateTriggered
        },
    )
}

/// All 64 directed edges of the Hasse diagram, each with its category.
pub fn hasse_transitions() -> Vec<Transition> {
    let mut out = Vec::with_capacity(64);
    for from in Cell::all() {
        for site in 0..4 {
            let to = Cell(from.0 ^ (1 << (3 - site)));
            let category = categorize(from, to).expect("one contact differs");
            out.push(Transition {
                from,
                to,
                site,
                touchdown: to.has(site),
                category,
            });
        }
    }
    out
}

/// A leap word: the thesis's equation, the cells as printed (zero-time cells suppressed,
/// rest and flight implicit) and the condition on the coordination time `t₂`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct LeapWord {
    pub equation: &'static str,
    pub printed: Vec<Cell>,
    pub condition: &'static str,
}

impl LeapWord {
    /// The whole path: rest, the printed cells, flight, with zero-time cells restored.
    pub fn path(&self) -> Vec<Cell> {
        let mut cells = vec![Cell::REST];
        cells.extend(&self.printed);
        cells.push(Cell::FLIGHT);
        expand_zero_time(&cells)
    }
}

/// Words (3.2)–(3.7). Word (3.7) is printed `(I_1001, I_1000, I_0001)`; after the rear leg
/// has lifted (`I_1000`) the next cell must be the front leg's stance `I_0100` — the mirror of
/// (3.2) — since `I_1000 → I_0001` would need the rear leg to land again (errata).
pub fn leap_words() -> Vec<LeapWord> {
    let c = |s: &str| Cell::from_label(s).expect("static label");
    let w = |equation, cells: [&str; 3], condition| LeapWord {
        equation,
        printed: cells.iter().map(|s| c(s)).collect(),
        condition,
    };
    vec![
        w("3.2", ["0110", "0010", "0001"], "t1a* < t2"),
        w("3.3", ["0110", "0101", "0001"], "0 < t2 < t1a*, t1a < t2a"),
        w("3.4", ["0110", "0101", "0100"], "0 < t2 < t1a*, t2a < t1a"),
        w("3.5", ["1001", "0101", "0001"], "t2a* < t2 < 0, t1a < t2a"),
        w("3.6", ["1001", "0101", "0100"], "t2a* < t2 < 0, t2a < t1a"),
        w("3.7", ["1001", "1000", "0100"], "t2 < t2a*"),
    ]
}

/// Restores the zero-time (bridge) cells between consecutive cells that differ by one
/// touchdown and one liftoff: the new contact is made first (the 0-DOF union cell, passed in no time),
/// then the old one breaks — a leg cannot lift a body end before it touches.
pub fn expand_zero_time(cells: &[Cell]) -> Vec<Cell> {
    let mut out: Vec<Cell> = Vec::with_capacity(cells.len() * 2);
    for &cell in cells {
        if let Some(&prev) = out.last() {
            let added = cell.0 & !prev.0;
            let removed = prev.0 & !cell.0;
            if added.count_ones() == 1 && removed.count_ones() == 1 {
                out.push(Cell(prev.0 | cell.0));
            }
        }
        out.push(cell);
    }
    out
}

/// The 18 allowable transitions of Fig. 3.3: every edge of every leap word's full path.
pub fn allowable_transitions() -> Vec<Transition> {
    let hasse = hasse_transitions();
    let mut out: Vec<Transition> = Vec::new();
    for word in leap_words() {
        for pair in word.path().windows(2) {
            let t = *hasse
                .iter()
                .find(|t| t.from == pair[0] && t.to == pair[1])
                .expect("word paths move along Hasse edges");
            if !out.contains(&t) {
                out.push(t);
            }
        }
    }
    out.sort_by_key(|t| (std::cmp::Reverse(t.from.n_contacts()), t.from, t.to));
    out
}

/// Compresses a sequence of visited cells into a word in the thesis's printed form: repeats
/// merged, the rest/flight ends dropped, and the zero-time *bridge* cells dropped — a cell that
/// is the union of its two neighbours when one contact is made and another breaks at once
/// (the inverse of [`expand_zero_time`]).
pub fn word_from_cells(cells: &[Cell]) -> Vec<Cell> {
    let mut merged: Vec<Cell> = cells.to_vec();
    merged.dedup();
    let is_bridge = |p: Cell, c: Cell, n: Cell| {
        c.0 == p.0 | n.0 && (p.0 & !n.0).count_ones() == 1 && (n.0 & !p.0).count_ones() == 1
    };
    let mut out: Vec<Cell> = Vec::with_capacity(merged.len());
    for (i, &c) in merged.iter().enumerate() {
        let bridge = i > 0 && i + 1 < merged.len() && is_bridge(merged[i - 1], c, merged[i + 1]);
        if !bridge {
            out.push(c);
        }
    }
    if out.first() == Some(&Cell::REST) {
        out.remove(0);
    }
    if out.last() == Some(&Cell::FLIGHT) {
        out.pop();
    }
    out
}

/// Which of (3.2)–(3.7) a visited cell sequence is (by its compressed word), if any.
pub fn match_leap_word(cells: &[Cell]) -> Option<&'static str> {
    let word = word_from_cells(cells);
    leap_words()
        .into_iter()
        .find(|w| w.printed == word)
        .map(|w| w.equation)
}

/// The whole complex as JSON (for Python): cells, Hasse edges, allowable edges, words,
/// strategies.
pub fn grc_json() -> serde_json::Value {
    let cells: Vec<_> = Cell::all()
        .map(|c| serde_json::json!({"label": c.label(), "contacts": c.contacts(), "dof": c.dof(), "fully_constrained": c.is_fully_constrained()}))
        .collect();
    let words: Vec<_> = leap_words()
        .iter()
        .map(|w| serde_json::json!({"equation": w.equation, "printed": w.printed, "path": w.path(), "condition": w.condition}))
        .collect();
    serde_json::json!({
        "sites": SITES,
        "cells": cells,
        "hasse": hasse_transitions(),
        "allowable": allowable_transitions(),
        "leap_words": words,
        "strategies": Strategy::ALL.iter().map(|s| s.to_string()).collect::<Vec<_>>(),
    })
}

/// A readable summary of the leap grammar.
pub fn leap_grammar_text() -> String {
    let mut s =
        String::from("Leap grammar (rest I_1010 -> flight I_0000; [..] = zero-time cells)\n");
    for w in leap_words() {
        let path: Vec<String> = w
            .path()
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let shown = i == 0 || c.is_flight() || w.printed.contains(c);
                if shown {
                    c.label()
                } else {
                    format!("[{}]", c.label())
                }
            })
            .collect();
        s.push_str(&format!(
            "  ({}) {}   if {}\n",
            w.equation,
            path.join(" -> "),
            w.condition
        ));
    }
    s
}
