//! The ground reaction complex: counts and consistency between the thesis's independent
//! statements (the 64-edge Hasse diagram, the category definitions, the "18 transitions over
//! 15 cells" of Fig. 3.3, and the leap words (3.2)–(3.7)).
use rhex_model::grc::*;
use rhex_model::leap::{Push, Strategy};
use std::collections::BTreeSet;

fn cell(s: &str) -> Cell {
    Cell::from_label(s).unwrap()
}

#[test]
fn hasse_diagram_is_all_single_contact_changes() {
    let hasse = hasse_transitions();
    // brute force over all ordered pairs of the 16 cells
    let brute: BTreeSet<(u8, u8)> = (0..16u8)
        .flat_map(|a| (0..16u8).map(move |b| (a, b)))
        .filter(|(a, b)| (a ^ b).count_ones() == 1)
        .collect();
    let got: BTreeSet<(u8, u8)> = hasse.iter().map(|t| (t.from.bits(), t.to.bits())).collect();
    assert_eq!(
        hasse.len(),
        4 * 16,
        "|I| 2^|I| directed edges (section 3.1.3)"
    );
    assert_eq!(got, brute);
    for t in &hasse {
        assert_eq!(t.touchdown, t.to.n_contacts() > t.from.n_contacts());
    }
}

#[test]
fn cells_have_the_dof_of_section_3_1_1() {
    let count = |d: Option<u32>| Cell::all().filter(|c| c.dof() == d).count();
    assert_eq!(
        (
            count(Some(3)),
            count(Some(2)),
            count(Some(1)),
            count(Some(0)),
            count(None)
        ),
        (1, 4, 6, 4, 1)
    );
    assert_eq!(Cell::REST.contacts(), vec!["FB", "RB"]);
    assert_eq!(
        cell("0111").contacts(),
        vec!["FL", "RB", "RL"],
        "the thesis's own example I_0111"
    );
}

#[test]
fn eighteen_allowable_transitions_over_fifteen_cells() {
    let allowable = allowable_transitions();
    assert_eq!(allowable.len(), 18, "Fig. 3.3: 64 reduced to 18");
    let cells: BTreeSet<Cell> = allowable.iter().flat_map(|t| [t.from, t.to]).collect();
    assert_eq!(cells.len(), 15, "15 of the 16 cells remain");
    assert!(!cells.contains(&Cell::OVERCONSTRAINED));
    let hasse = hasse_transitions();
    for t in &allowable {
        assert!(hasse.contains(t), "{} -> {} is a Hasse edge", t.from, t.to);
        assert!(
            matches!(
                t.category,
                TransitionCategory::ControlTriggered | TransitionCategory::StateTriggered
            ),
            "{} -> {} is possible and desirable, got {:?}",
            t.from,
            t.to,
            t.category
        );
    }
    // leg touchdowns are control-triggered, every liftoff is state-triggered
    let control = allowable
        .iter()
        .filter(|t| t.category == TransitionCategory::ControlTriggered)
        .count();
    assert_eq!(control, allowable.iter().filter(|t| t.touchdown).count());
    assert!(
        allowable.iter().all(|t| !t.touchdown || t.site % 2 == 1),
        "no body landing"
    );
}

#[test]
fn categories_follow_the_thesis_examples() {
    use TransitionCategory::*;
    // the examples of section 3.1.3 (the printed I_1010 -> I_1101 is read as I_1110: errata)
    assert_eq!(
        categorize(cell("1010"), cell("1110")),
        Some(ControlTriggered)
    );
    assert_eq!(
        categorize(cell("0000"), cell("0100")),
        Some(SometimesControlTriggered)
    );
    assert_eq!(categorize(cell("0101"), cell("0001")), Some(StateTriggered));
    assert_eq!(categorize(cell("1010"), cell("1000")), Some(Impossible));
    assert_eq!(categorize(cell("0000"), cell("1000")), Some(Undesirable));
    assert_eq!(
        categorize(cell("1010"), cell("1101")),
        None,
        "three contacts change"
    );
}

/// Every path from rest to flight in the allowable digraph is one of the six words, and every
/// word is such a path: the words and the edge set say the same thing.
#[test]
fn leap_grammar_is_exactly_the_six_words() {
    let allowable = allowable_transitions();
    fn paths(at: Cell, edges: &[Transition], stack: &mut Vec<Cell>, out: &mut Vec<Vec<Cell>>) {
        stack.push(at);
        assert!(stack.len() <= 16, "the allowable graph has no cycle");
        if at == Cell::FLIGHT {
            out.push(stack.clone());
        }
        for t in edges.iter().filter(|t| t.from == at) {
            paths(t.to, edges, stack, out);
        }
        stack.pop();
    }
    let mut all = Vec::new();
    paths(Cell::REST, &allowable, &mut Vec::new(), &mut all);
    let from_graph: BTreeSet<Vec<Cell>> = all.into_iter().collect();
    let from_words: BTreeSet<Vec<Cell>> = leap_words().iter().map(|w| w.path()).collect();
    assert_eq!(from_graph, from_words);
    assert_eq!(from_words.len(), 6);
    for w in leap_words() {
        let path = w.path();
        assert_eq!(path.first(), Some(&Cell::REST));
        assert_eq!(path.last(), Some(&Cell::FLIGHT));
        for pair in path.windows(2) {
            assert_eq!(
                (pair[0].bits() ^ pair[1].bits()).count_ones(),
                1,
                "word ({}) moves one contact at a time",
                w.equation
            );
        }
        assert_eq!(
            word_from_cells(&path),
            w.printed,
            "suppressing zero-time cells gives the printed word"
        );
        assert_eq!(match_leap_word(&path), Some(w.equation));
    }
}

#[test]
fn words_mirror_front_and_rear() {
    // swapping front and rear (FB FL RB RL -> RB RL FB FL) maps the set of words onto itself
    let mirror = |c: Cell| Cell::from_bits(((c.bits() & 0b0011) << 2) | (c.bits() >> 2)).unwrap();
    let words: BTreeSet<Vec<Cell>> = leap_words().iter().map(|w| w.path()).collect();
    let mirrored: BTreeSet<Vec<Cell>> = words
        .iter()
        .map(|p| p.iter().map(|&c| mirror(c)).collect())
        .collect();
    assert_eq!(words, mirrored);
}

#[test]
fn word_matching_tolerates_repeats_and_rejects_strangers() {
    let seq: Vec<Cell> = [
        "1010", "1010", "1110", "0110", "0110", "0111", "0101", "0001", "0000",
    ]
    .map(cell)
    .to_vec();
    assert_eq!(match_leap_word(&seq), Some("3.3"));
    let odd: Vec<Cell> = ["1010", "1110", "0110", "0100", "0000"].map(cell).to_vec();
    assert_eq!(match_leap_word(&odd), None);
}

#[test]
fn bad_labels_and_strategies_are_typed_errors() {
    for bad in ["", "010", "01010", "01x1", "0101 "] {
        assert!(Cell::from_label(bad).is_err(), "{bad:?}");
    }
    assert!(Cell::from_bits(16).is_err());
    assert_eq!(
        "(+, -)".parse::<Strategy>().unwrap(),
        Strategy::new(Push::Plus, Push::Minus)
    );
    let mm: Strategy = "--".parse().unwrap();
    assert_eq!((mm.front.sign(), mm.rear.sign()), (-1.0, -1.0));
    assert!("+0".parse::<Strategy>().is_err());
    for s in Strategy::ALL {
        assert_eq!(s.to_string().parse::<Strategy>().unwrap(), s);
    }
}

#[test]
fn json_round_trips_the_counts() {
    let v = grc_json();
    assert_eq!(v["cells"].as_array().unwrap().len(), 16);
    assert_eq!(v["hasse"].as_array().unwrap().len(), 64);
    assert_eq!(v["allowable"].as_array().unwrap().len(), 18);
    assert_eq!(
        v["leap_words"][5]["printed"],
        serde_json::json!(["1001", "1000", "0100"])
    );
    assert!(leap_grammar_text().contains("(3.2) 1010 -> [1110] -> 0110"));
}
