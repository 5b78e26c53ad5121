//! A URDF's XML as urdfdom (through which Pinocchio reads URDF) reads it, before `urdf-rs`
//! parses it, and the field a malformed file gets wrong.
//!
//! [`as_urdfdom_reads_it`] drops what the model does not read — a link's `visual` and
//! `collision` blocks, `material`s — so an element `urdf-rs` would refuse there (an empty
//! `<texture/>`, which urdfdom's schema allows) does not stop the load, and keeps only the
//! first of an element urdfdom reads once (its `FirstChildElement`: a joint's `origin`,
//! `axis`, `limit`, …, a link's `inertial`, an inertial's `mass`, …), where `urdf-rs` refuses
//! a second one as a duplicate field (Ghost Robotics' Spirit 40 in `pybullet_data` gives a
//! joint two `axis` elements; Pinocchio takes the first).
//!
//! When `urdf-rs` refuses the text, [`malformed_field`] finds the attribute or element it
//! refused and names it as the reader's other errors do (`joint[NAME].origin.xyz`,
//! `link[NAME].inertial.mass`): a vector without three numbers (`0.07, 0, -0.69`: commas; four
//! angles), a number that is not one (`-1.57.`), an unexpanded xacro expression (`$(arg …)`,
//! `${…}`), a missing required attribute or element, an unknown joint type.
use super::error::SpatialError;
use quick_xml::events::{BytesStart, Event};

/// The elements of a URDF that the model does not read: a link's looks and collision shapes
/// and the materials they name.
const UNREAD: [&[u8]; 3] = [b"visual", b"collision", b"material"];

/// Whether urdfdom reads each child of the element at the end of `path` (the open elements'
/// names from the root) once: the children of a `joint` or a `link` below `robot`, and of a
/// link's `inertial`. (A link's `visual` and `collision` blocks, which it reads all of, are
/// [`UNREAD`].)
fn reads_children_once(path: &[Vec<u8>]) -> bool {
    match path {
        [robot, element] => robot == b"robot" && (element == b"joint" || element == b"link"),
        [robot, link, inertial] => robot == b"robot" && link == b"link" && inertial == b"inertial",
        _ => false,
    }
}

/// An open element: its name and the names of the children seen so far.
struct Open {
    name: Vec<u8>,
    children: Vec<Vec<u8>>,
}

/// `text` without its [`UNREAD`] elements and without every element after the first of its
/// name where urdfdom reads one ([`reads_children_once`]), each with whatever it holds; every
/// other event of the XML as it was. The message of an XML error otherwise (with its line).
pub(super) fn as_urdfdom_reads_it(text: &str) -> Result<String, String> {
    let mut reader = quick_xml::Reader::from_str(text);
    let mut writer = quick_xml::Writer::new(Vec::with_capacity(text.len()));
    let mut open: Vec<Open> = Vec::new();
    // how deep the reader is inside an element that is dropped
    let mut dropped = 0usize;
    loop {
        let event = reader.read_event().map_err(|e| {
            let at = reader.error_position() as usize;
            format!("XML at line {}: {e}", line_of(text, at))
        })?;
        let keep = match &event {
            Event::Eof => break,
            Event::Start(e) | Event::Empty(e) => {
                let is_start = matches!(event, Event::Start(_));
                if dropped > 0 {
                    dropped += usize::from(is_start);
                    false
                } else if dropped_here(&mut open, e) {
                    dropped = usize::from(is_start);
                    false
                } else {
                    if is_start {
                        open.push(Open {
                            name: e.name().as_ref().to_vec(),
                            children: Vec::new(),
                        });
                    }
                    true
                }
            }
            Event::End(_) if dropped > 0 => {
                dropped -= 1;
                false
            }
            Event::End(_) => {
                open.pop();
                true
            }
            _ => dropped == 0,
        };
        if keep {
            writer.write_event(event).map_err(|e| e.to_string())?;
        }
    }
    String::from_utf8(writer.into_inner()).map_err(|e| e.to_string())
}

/// Whether the element `e`, opening inside `open`, is dropped (and if not, records it as a
/// child of its parent).
fn dropped_here(open: &mut [Open], e: &BytesStart) -> bool {
    let name = e.name();
    if UNREAD.contains(&name.as_ref()) {
        return true;
    }
    let path: Vec<Vec<u8>> = open.iter().map(|o| o.name.clone()).collect();
    let Some(parent) = open.last_mut() else {
        return false;
    };
    if reads_children_once(&path) && parent.children.iter().any(|c| c == name.as_ref()) {
        return true;
    }
    parent.children.push(name.as_ref().to_vec());
    false
}

/// The 1-based line of byte `at` of `text`.
fn line_of(text: &str, at: usize) -> usize {
    1 + text.as_bytes()[..at.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

/// What an attribute holds.
#[derive(Clone, Copy)]
enum Value {
    /// One number.
    Number,
    /// Three numbers separated by white space.
    Vector,
    /// A name.
    Name,
}

/// An element's attributes that `urdf-rs` reads: name, value, required.
fn attributes(
    parent: &str,
    element: &str,
    version: (u32, u32),
) -> &'static [(&'static str, Value, bool)] {
    use Value::{Name, Number, Vector};
    // before URDF 1.2 a limit's velocity has no default (urdfdom and urdf-rs both want it)
    let velocity_required = version < (1, 2);
    match (parent, element) {
        ("joint" | "inertial", "origin") => &[("xyz", Vector, false), ("rpy", Vector, false)],
        ("joint", "axis") => &[("xyz", Vector, true)],
        ("joint", "parent" | "child") => &[("link", Name, true)],
        ("joint", "limit") if velocity_required => &[
            ("lower", Number, false),
            ("upper", Number, false),
            ("effort", Number, false),
            ("velocity", Number, true),
        ],
        ("joint", "limit") => &[
            ("lower", Number, false),
            ("upper", Number, false),
            ("effort", Number, false),
            ("velocity", Number, false),
            ("acceleration", Number, false),
            ("deceleration", Number, false),
            ("jerk", Number, false),
        ],
        ("joint", "dynamics") => &[("damping", Number, false), ("friction", Number, false)],
        ("joint", "mimic") => &[
            ("joint", Name, true),
            ("multiplier", Number, false),
            ("offset", Number, false),
        ],
        ("joint", "safety_controller") => &[
            ("soft_lower_limit", Number, false),
            ("soft_upper_limit", Number, false),
            ("k_position", Number, false),
            ("k_velocity", Number, true),
        ],
        ("joint", "calibration") => &[("rising", Number, false), ("falling", Number, false)],
        ("inertial", "mass") => &[("value", Number, true)],
        ("inertial", "inertia") => &[
            ("ixx", Number, true),
            ("ixy", Number, true),
            ("ixz", Number, true),
            ("iyy", Number, true),
            ("iyz", Number, true),
            ("izz", Number, true),
        ],
        _ => &[],
    }
}

/// The children an element must have for `urdf-rs`.
fn required_children(element: &str) -> &'static [&'static str] {
    match element {
        "joint" => &["parent", "child"],
        "inertial" => &["mass", "inertia"],
        _ => &[],
    }
}

/// The joint types `urdf-rs` knows (the model refuses some of them by name later).
const JOINT_TYPES: [&str; 7] = [
    "revolute",
    "continuous",
    "prismatic",
    "fixed",
    "floating",
    "planar",
    "spherical",
];

fn invalid(field: String, reason: impl Into<String>) -> SpatialError {
    SpatialError::InvalidUrdf {
        field,
        reason: reason.into(),
    }
}

/// Why `value` is not what `kind` asks, if it is not.
fn malformed(value: &str, kind: Value) -> Option<String> {
    let xacro = || {
        if value.contains("$(") || value.contains("${") {
            " (an unexpanded xacro expression: run `xacro` on the file first)"
        } else {
            ""
        }
    };
    match kind {
        Value::Name => None,
        Value::Number => value
            .trim()
            .parse::<f64>()
            .is_err()
            .then(|| format!("`{value}` is not a number{}", xacro())),
        Value::Vector => {
            let parts: Vec<&str> = value.split_whitespace().collect();
            let numbers = parts.iter().all(|p| p.parse::<f64>().is_ok());
            (!numbers || parts.len() != 3).then(|| {
                format!(
                    "`{value}` is not three numbers separated by spaces{}",
                    xacro()
                )
            })
        }
    }
}

/// The field of a URDF that `urdf-rs` refuses, read from the text ([`as_urdfdom_reads_it`]'s
/// output) as `urdf-rs` reads it: the first, in the file's order, of a malformed or missing
/// attribute, a missing required element or an unknown joint type, below the `robot`'s links
/// and joints. `None` when the text shows none of them (the caller then passes on `urdf-rs`'s
/// own message).
pub(super) fn malformed_field(text: &str) -> Option<SpatialError> {
    let mut reader = quick_xml::Reader::from_str(text);
    // the open elements' names, the field of the link or joint they are in, and each open
    // element's children so far
    let mut path: Vec<String> = Vec::new();
    let mut children: Vec<Vec<String>> = Vec::new();
    let mut owner = String::new();
    let mut version = (1, 0);
    let (mut links, mut joints) = (0usize, 0usize);
    loop {
        let event = reader.read_event().ok()?;
        let (e, is_start) = match &event {
            Event::Eof => return None,
            Event::Start(e) => (e, true),
            Event::Empty(e) => (e, false),
            Event::End(_) => {
                let element = path.pop()?;
                let seen = children.pop()?;
                if let Some(error) = missing_child(&owner, &path, &element, &seen) {
                    return Some(error);
                }
                continue;
            }
            _ => continue,
        };
        let name = String::from_utf8_lossy(e.name().as_ref()).into_owned();
        let attribute = |key: &str| {
            e.try_get_attribute(key)
                .ok()
                .flatten()
                .and_then(|a| a.unescape_value().ok().map(|v| v.into_owned()))
        };
        if let Some(seen) = children.last_mut() {
            seen.push(name.clone());
        }
        let in_robot = path.len() == 1 && path[0] == "robot";
        if path.is_empty() && name == "robot" {
            version = attribute("version")
                .and_then(|v| {
                    let (major, minor) = v.trim().split_once('.')?;
                    Some((major.parse().ok()?, minor.parse().ok()?))
                })
                .unwrap_or((1, 0));
        } else if in_robot && (name == "link" || name == "joint") {
            let index = if name == "link" {
                &mut links
            } else {
                &mut joints
            };
            *index += 1;
            owner = match attribute("name") {
                Some(n) => format!("{name}[{n}]"),
                None => return Some(invalid(format!("{name}[#{index}]"), "no `name` attribute")),
            };
            if name == "joint" {
                match attribute("type") {
                    None => return Some(invalid(owner + ".type", "missing")),
                    Some(t) if !JOINT_TYPES.contains(&t.as_str()) => {
                        return Some(invalid(
                            owner + ".type",
                            format!(
                                "unknown joint type `{t}` (URDF's: {})",
                                JOINT_TYPES.join(", ")
                            ),
                        ))
                    }
                    Some(_) => {}
                }
            }
        } else if let Some(parent) = path
            .last()
            .filter(|_| matches!(path.get(1).map(String::as_str), Some("link" | "joint")))
        {
            for &(key, kind, required) in attributes(parent, &name, version) {
                let field = format!("{}.{key}", field_of(&owner, &path, &name));
                // a mass's `value` is the mass
                let field = field
                    .strip_suffix(".mass.value")
                    .map_or(field.clone(), |f| f.to_owned() + ".mass");
                match attribute(key) {
                    None if required => return Some(invalid(field, "missing")),
                    None => {}
                    Some(value) => {
                        if let Some(reason) = malformed(&value, kind) {
                            return Some(invalid(field, reason));
                        }
                    }
                }
            }
        }
        if is_start {
            path.push(name);
            children.push(Vec::new());
        } else if let Some(error) = missing_child(&owner, &path, &name, &[]) {
            return Some(error);
        }
    }
}

/// The field of `element` inside the open `path` below the link or joint `owner`:
/// `joint[j].origin`, `link[l].inertial.mass`.
fn field_of(owner: &str, path: &[String], element: &str) -> String {
    let inner: Vec<&str> = path.iter().skip(2).map(String::as_str).collect();
    std::iter::once(owner)
        .chain(inner)
        .chain(std::iter::once(element))
        .collect::<Vec<_>>()
        .join(".")
}

/// The error for `element` (closing inside `path`, below `owner`) without a child it must have.
fn missing_child(
    owner: &str,
    path: &[String],
    element: &str,
    seen: &[String],
) -> Option<SpatialError> {
    let needs = match (path.len(), element) {
        (1, "joint") => required_children(element),
        (2, "inertial") if path[1] == "link" => required_children(element),
        _ => &[],
    };
    let missing = needs.iter().find(|c| !seen.iter().any(|s| s == *c))?;
    let field = if element == "joint" {
        format!("{owner}.{missing}")
    } else {
        format!("{}.{missing}", field_of(owner, path, element))
    };
    Some(invalid(field, "missing"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_element_read_once_is_dropped_and_lists_are_kept() {
        let text = r#"<robot name="r"><link name="a"><inertial><mass value="1"/><mass value="2"/></inertial><inertial><mass value="3"/></inertial></link><link name="b"/><joint name="j" type="revolute"><axis xyz="1 0 0"/><axis xyz="0 1 0"></axis><parent link="a"/><child link="b"/></joint></robot>"#;
        let read = as_urdfdom_reads_it(text).unwrap();
        assert_eq!(
            read,
            r#"<robot name="r"><link name="a"><inertial><mass value="1"/></inertial></link><link name="b"/><joint name="j" type="revolute"><axis xyz="1 0 0"/><parent link="a"/><child link="b"/></joint></robot>"#
        );
    }
}
