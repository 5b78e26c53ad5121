//! Collision shapes of the body and links (issue 30, item 4): what a description's
//! `collision` entries expand to, the errors that name a bad one, and the depth
//! [`outline_penetration`] measures. Frames (docs/conventions.md): NED, z down,
//! `q = [θ…, x, z, φ]`, a body point `p` at `X + R(φ) p` with
//! `R(φ) = [[cos φ, sin φ], [−sin φ, cos φ]]`.
use nalgebra::Vector2;
use selfmanip_core::contact::{contact_gap, outline_penetration};
use selfmanip_core::kinematics::Kinematics;
use selfmanip_core::model::{ContactShape, Friction, OutlineShape};
use selfmanip_core::{CoreError, FlatGround, Model, RobotDescription};

#[path = "common/spike.rs"]
mod spike;
use spike::Spike;

const STICK: &str = "{ kind = \"sticking\", mu = 0.8 }";

/// A 2 kg body with one two-link leg `front` (hip at `(0.2, 0)`, links 0.15 m), the body's
/// and the knee link's `collision` lists given in TOML (inline arrays).
fn text(body_collision: &str, shin_collision: &str) -> String {
    format!(
        "name = \"r\"\n[body]\nmass_kg = 2.0\ninertia_kg_m2 = 0.03\ncollision = [{body_collision}]\n\
         [[legs]]\nname = \"front\"\nhip_m = [0.2, 0.0]\n\
         [[legs.links]]\nlength_m = 0.15\n\
         [[legs.links]]\nlength_m = 0.15\ncollision = [{shin_collision}]\n\
         [[contacts]]\nname = \"foot\"\nleg = \"front\"\n\
         shape = {{ kind = \"point\", position_m = [0.0, 0.15] }}\nfriction = {STICK}\n"
    )
}

fn build(body_collision: &str, shin_collision: &str) -> Result<Model, CoreError> {
    RobotDescription::from_toml_str(&text(body_collision, shin_collision))?.build()
}

fn point(model: &Model, name: &str) -> Vector2<f64> {
    let k = model.contact_index(name).unwrap();
    match model.contacts[k].shape {
        ContactShape::Point { position_m } => position_m,
        ref s => panic!("{name} is {s:?}"),
    }
}

fn circle(model: &Model, name: &str) -> (Vector2<f64>, f64) {
    let k = model.contact_index(name).unwrap();
    match model.contacts[k].shape {
        ContactShape::Arc {
            center_m,
            radius_m,
            normal_range_rad: None,
        } => (center_m, radius_m),
        ref s => panic!("{name} is {s:?}"),
    }
}

#[test]
fn a_box_is_its_four_corners_a_stadium_its_end_circles_a_circle_itself() {
    let m = build(
        &format!(
            "{{ shape = {{ kind = \"box\", size_m = [0.5, 0.1] }}, center_m = [0.01, 0.02], \
             friction = {STICK} }}, \
             {{ shape = {{ kind = \"circle\", radius_m = 0.03 }}, friction = {{ kind = \"sliding\" }} }}"
        ),
        &format!("{{ shape = {{ kind = \"stadium\", length_m = 0.1, radius_m = 0.02 }}, friction = {STICK} }}"),
    )
    .unwrap();
    // the described contact first, then the body's shapes, then the links'
    let names: Vec<&str> = m.contacts.iter().map(|c| c.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "foot",
            "body.collision[0].corner[0]",
            "body.collision[0].corner[1]",
            "body.collision[0].corner[2]",
            "body.collision[0].corner[3]",
            "body.collision[1]",
            "front[1].collision[0].end[0]",
            "front[1].collision[0].end[1]",
        ]
    );
    // the body's box: `l` along the body's x, `h` along z, about its centre
    let mut corners: Vec<[f64; 2]> = (0..4)
        .map(|j| point(&m, &format!("body.collision[0].corner[{j}]")))
        .map(|p| [p.x, p.y])
        .collect();
    corners.sort_by(|a, b| a.partial_cmp(b).unwrap());
    let expect = [[-0.24, -0.03], [-0.24, 0.07], [0.26, -0.03], [0.26, 0.07]];
    for (c, e) in corners.iter().zip(expect) {
        assert!(
            (c[0] - e[0]).abs() < 1e-15 && (c[1] - e[1]).abs() < 1e-15,
            "{c:?} {e:?}"
        );
    }
    // the body's circle at the body's origin (no centre given)
    assert_eq!(circle(&m, "body.collision[1]"), (Vector2::zeros(), 0.03));
    // the shin's stadium along the link (+z) about its middle (0, 0.075)
    let (e0, r0) = circle(&m, "front[1].collision[0].end[0]");
    let (e1, r1) = circle(&m, "front[1].collision[0].end[1]");
    assert_eq!((r0, r1), (0.02, 0.02));
    assert!((e0 - Vector2::new(0.0, 0.025)).norm() < 1e-15, "{e0}");
    assert!((e1 - Vector2::new(0.0, 0.125)).norm() < 1e-15, "{e1}");
    // each site on its part, with the friction given
    let shin = m.contact_index("front[1].collision[0].end[0]").unwrap();
    assert_eq!(m.contacts[shin].link, Some(1));
    assert_eq!(m.contacts[shin].friction, Friction::Sticking { mu: 0.8 });
    let c = m.contact_index("body.collision[1]").unwrap();
    assert_eq!(
        (m.contacts[c].link, m.contacts[c].friction),
        (None, Friction::Sliding)
    );
    // the outlines, with their sites
    assert_eq!(m.outlines.len(), 3);
    assert_eq!(m.outlines[0].contacts, 1..5);
    assert_eq!(m.outlines[2].name, "front[1].collision[0]");
    assert_eq!(m.outlines[2].contacts, 6..8);
    assert!(matches!(
        m.outlines[0].shape,
        OutlineShape::Box {
            half_m: [0.25, 0.05],
            ..
        }
    ));
}

#[test]
fn a_description_without_collision_is_unchanged_and_round_trips_with_it() {
    let plain = build("", "").unwrap();
    assert_eq!(plain.n_contacts(), 1);
    assert!(plain.outlines.is_empty());
    // written back without the empty lists
    let d = RobotDescription::from_toml_str(&text("", "")).unwrap();
    assert!(!d.to_toml_string().contains("collision"));
    let with =
        format!("{{ shape = {{ kind = \"box\", size_m = [0.5, 0.1] }}, friction = {STICK} }}");
    let d = RobotDescription::from_toml_str(&text(&with, "")).unwrap();
    let again = RobotDescription::from_toml_str(&d.to_toml_string()).unwrap();
    assert_eq!(again, d);
    assert_eq!(again.build().unwrap(), d.build().unwrap());
}

/// The field an invalid description's error names (and its reason), or the parse message.
fn error_of(body_collision: &str, shin_collision: &str) -> String {
    match build(body_collision, shin_collision) {
        Err(CoreError::InvalidDescription { field, reason }) => format!("{field}: {reason}"),
        Err(CoreError::Parse { message, .. }) => message,
        other => panic!("not an error: {other:?}"),
    }
}

#[test]
fn a_bad_shape_is_an_error_that_names_its_field() {
    let shape = |s: &str| format!("{{ shape = {s}, friction = {STICK} }}");
    for (body, shin, field) in [
        (shape("{ kind = \"box\", size_m = [-0.5, 0.1] }"), String::new(), "body.collision[0].shape.size_m[0]: must be non-negative"),
        (shape("{ kind = \"box\", size_m = [0.5, nan] }"), String::new(), "body.collision[0].shape.size_m[1]: must be finite"),
        (shape("{ kind = \"box\", size_m = [0.5, 0.0] }"), String::new(), "body.collision[0].shape.size_m[1]: must be positive"),
        (shape("{ kind = \"circle\", radius_m = inf }"), String::new(), "body.collision[0].shape.radius_m: must be finite"),
        (String::new(), shape("{ kind = \"stadium\", length_m = 0.0, radius_m = 0.01 }"), "legs[0].links[1].collision[0].shape.length_m: must be positive"),
        (String::new(), shape("{ kind = \"stadium\", length_m = 0.1, radius_m = -0.01 }"), "legs[0].links[1].collision[0].shape.radius_m: must be non-negative"),
        (
            format!("{}, {{ shape = {{ kind = \"circle\", radius_m = 0.1 }}, center_m = [0.0, nan], friction = {STICK} }}", shape("{ kind = \"circle\", radius_m = 0.1 }")),
            String::new(),
            "body.collision[1].center_m: must be finite",
        ),
        (
            "{ shape = { kind = \"circle\", radius_m = 0.1 }, friction = { kind = \"sticking\", mu = -1.0 } }".into(),
            String::new(),
            "body.collision[0].friction.mu: must be non-negative",
        ),
    ] {
        assert_eq!(error_of(&body, &shin), field);
    }
}

#[test]
fn an_unknown_kind_or_key_is_a_parse_error_that_names_the_entry() {
    let e = error_of(
        &format!("{{ shape = {{ kind = \"ellipse\", radius_m = 0.1 }}, friction = {STICK} }}"),
        "",
    );
    assert!(
        e.contains("collision[0]") && e.contains("unknown variant `ellipse`"),
        "{e}"
    );
    for kind in ["`box`", "`stadium`", "`circle`"] {
        assert!(e.contains(kind), "{e}");
    }
    let e = error_of(
        "",
        &format!(
            "{{ shape = {{ kind = \"circle\", radius_m = 0.1 }}, friction = {STICK} }}, \
             {{ shape = {{ kind = \"box\", size_m = [0.1, 0.1], radius_m = 0.1 }}, friction = {STICK} }}"
        ),
    );
    assert!(
        e.contains("collision[1]") && e.contains("unknown field `radius_m`"),
        "{e}"
    );
    let e = error_of(&format!("{{ shape = {{ kind = \"circle\", radius_m = 0.1 }}, offset = [0, 0], friction = {STICK} }}"), "");
    assert!(
        e.contains("collision[0]") && e.contains("unknown field `offset`"),
        "{e}"
    );
    let e = error_of("{ shape = { kind = \"circle\", radius_m = 0.1 } }", "");
    assert!(
        e.contains("collision[0]") && e.contains("missing field `friction`"),
        "{e}"
    );
    // JSON the same
    let json = r#"{"name": "r", "body": {"mass_kg": 1.0, "inertia_kg_m2": 0.1,
        "collision": [{"shape": {"kind": "box", "size_m": [0.1, 0.1, 0.1]}, "friction": {"kind": "sliding"}}]}}"#;
    let e = RobotDescription::from_json_str(json)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("collision[0]") && e.contains("exactly 2 numbers"),
        "{e}"
    );
}

#[test]
fn a_site_name_taken_twice_or_too_many_sites_name_the_shape() {
    // a described contact called like a corner
    let t = text(
        &format!("{{ shape = {{ kind = \"box\", size_m = [0.5, 0.1] }}, friction = {STICK} }}"),
        "",
    )
    .replace("name = \"foot\"", "name = \"body.collision[0].corner[2]\"");
    let e = RobotDescription::from_toml_str(&t)
        .unwrap()
        .build()
        .unwrap_err();
    let CoreError::InvalidDescription { field, reason } = e else {
        panic!("{e:?}")
    };
    assert_eq!(field, "body.collision[0]");
    assert!(reason.contains("`body.collision[0].corner[2]`"), "{reason}");
    // eight boxes are 32 corners, with the foot 33 sites
    let boxes =
        vec![
            format!("{{ shape = {{ kind = \"box\", size_m = [0.5, 0.1] }}, friction = {STICK} }}");
            8
        ];
    let e = error_of(&boxes.join(", "), "");
    assert!(
        e.starts_with("body.collision[7]: at most 32 contact sites"),
        "{e}"
    );
    assert_eq!(build(&boxes[..7].join(", "), "").unwrap().n_contacts(), 29);
}

fn kinematics(m: &Model, q: &[f64]) -> Kinematics {
    let mut kin = Kinematics::default();
    kin.compute(m, q, &vec![0.0; q.len()]);
    kin
}

#[test]
fn the_depth_of_an_outline_is_its_deepest_point_below_the_ground() {
    let m = build(
        &format!("{{ shape = {{ kind = \"box\", size_m = [0.4, 0.1] }}, friction = {STICK} }}"),
        "",
    )
    .unwrap();
    // body pitched by φ at height z: the lowest corner, (±0.2, 0.05) in the body frame, is at
    // world z + 0.2 |sin φ| + 0.05 cos φ
    let (z, phi) = (-0.1, 0.4_f64);
    let lowest = z + 0.2 * phi.sin() + 0.05 * phi.cos();
    let q = [0.3, -0.5, 1.0, z, phi];
    let kin = kinematics(&m, &q);
    let p = outline_penetration(&m, &kin, &FlatGround, 0.0).unwrap();
    assert_eq!(p.outline, 0);
    assert!(
        (p.depth_m - lowest).abs() < 1e-15,
        "{} vs {lowest}",
        p.depth_m
    );
    // the same depth is what the corner's guard sees
    let k = m.contact_index("body.collision[0].corner[0]").unwrap();
    assert!((contact_gap(&m, &kin, &FlatGround, k) + lowest).abs() < 1e-15);
    // below the tolerance, or clear of the ground: nothing
    assert!(outline_penetration(&m, &kin, &FlatGround, lowest + 1e-9).is_none());
    let clear = kinematics(&m, &[0.3, -0.5, 1.0, -0.3, phi]);
    assert!(outline_penetration(&m, &clear, &FlatGround, 0.0).is_none());
    // a model without outlines has none
    let plain = build("", "").unwrap();
    assert!(
        outline_penetration(&plain, &kinematics(&plain, &[0.0; 5]), &FlatGround, 0.0).is_none()
    );
}

#[test]
fn a_terrain_corner_inside_an_outline_is_a_penetration_its_sites_cannot_see() {
    let m = build(
        &format!(
            "{{ shape = {{ kind = \"box\", size_m = [0.4, 0.1] }}, friction = {STICK} }}, \
             {{ shape = {{ kind = \"stadium\", length_m = 0.2, radius_m = 0.03 }}, center_m = [0.0, -0.3], \
             friction = {STICK} }}"
        ),
        "",
    )
    .unwrap();
    // level body, centre at z = −0.1: box bottom at −0.05, stadium axis at −0.4; a spike tip
    // at (0.05, −0.07) is 0.02 inside the box's bottom edge and 0.15 from its ends
    let kin = kinematics(&m, &[0.3, -0.5, 1.0, -0.1, 0.0]);
    for k in m.outlines.iter().flat_map(|o| o.contacts.clone()) {
        assert!(contact_gap(&m, &kin, &FlatGround, k) > 0.0);
    }
    let spike = Spike {
        tip: Vector2::new(1.05, -0.07),
    };
    let p = outline_penetration(&m, &kin, &spike, 0.0).unwrap();
    assert_eq!(p.outline, 0);
    assert!((p.depth_m - 0.02).abs() < 1e-12, "{}", p.depth_m);
    // into the stadium's straight side: the tip 0.01 below its axis, 0.05 from its middle,
    // is 0.03 − 0.01 inside
    let spike = Spike {
        tip: Vector2::new(1.05, -0.39),
    };
    let p = outline_penetration(&m, &kin, &spike, 0.0).unwrap();
    assert_eq!(p.outline, 1);
    assert!((p.depth_m - 0.02).abs() < 1e-12, "{}", p.depth_m);
    // beyond the stadium's end circle: outside by |(0.15, 0.02) − (0.1, 0)| − 0.03
    let spike = Spike {
        tip: Vector2::new(1.15, -0.38),
    };
    let outside = (0.05f64.hypot(0.02)) - 0.03;
    assert!(outside > 0.0);
    assert!(outline_penetration(&m, &kin, &spike, 0.0).is_none());
    assert!(outline_penetration(&m, &kin, &spike, -outside - 1e-12).is_some());
    assert!(outline_penetration(&m, &kin, &spike, -outside + 1e-12).is_none());
}
