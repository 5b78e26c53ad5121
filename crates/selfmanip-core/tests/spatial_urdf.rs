//! The URDF reader: fixed joints merged, massless links kept massless, and every bad input a
//! typed error naming its field.
mod spatial_support;
use selfmanip_core::spatial::*;
use selfmanip_core::CoreError;
use spatial_support::*;

fn two_links(joints: &str, mass_b: &str) -> String {
    format!(
        r#"<robot name="r"><link name="a"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
        <link name="b"><inertial><mass value="{mass_b}"/><inertia ixx="0.1" ixy="0" ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial></link>{joints}</robot>"#
    )
}

fn joint(name: &str, kind: &str, parent: &str, child: &str, xyz: &str) -> String {
    format!(
        r#"<joint name="{name}" type="{kind}"><origin xyz="{xyz}"/><parent link="{parent}"/><child link="{child}"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>"#
    )
}

fn field_of(err: SpatialError) -> String {
    match err {
        SpatialError::InvalidUrdf { field, .. } => field,
        other => panic!("expected InvalidUrdf, got {other:?}"),
    }
}

/// The core error a spatial error wraps.
fn core_error(err: SpatialError) -> CoreError {
    match err {
        SpatialError::Core(e) => e,
        other => panic!("expected a core error, got {other:?}"),
    }
}

#[test]
fn the_quadruped_has_its_joints_frames_and_mass() {
    let model = quadruped();
    assert_eq!((model.nq, model.nv, model.joints.len()), (19, 18, 13));
    // fixed joints merged: 12.0 + 0.2 (imu) on the base; legs 4 × (0.6 + 1.1 + 0.25 + 0.06)
    assert!((model.inertias[0].mass - 12.2).abs() < 1e-12);
    assert!((model.total_mass() - (12.2 + 4.0 * 2.01)).abs() < 1e-12);
    for name in FEET
        .iter()
        .chain(KNEES.iter())
        .chain(["imu", "imu_fixed", "trunk", "root_joint"].iter())
    {
        model.frame_id(name).unwrap();
    }
    let shinless = quadruped_massless_shins();
    let knee = shinless
        .joints
        .iter()
        .position(|j| j.name == "FL_knee")
        .unwrap();
    assert_eq!(shinless.inertias[knee].mass, 0.0);
    assert_eq!(shinless.inertias[knee].matrix().amax(), 0.0);
    // a fixed base: nq = nv = 12
    let fixed = SpatialModel::from_urdf_file(QUADRUPED, BaseKind::Fixed, None).unwrap();
    assert_eq!((fixed.nq, fixed.nv), (12, 12));
}

#[test]
fn bad_urdf_names_the_field() {
    let free = BaseKind::FreeFlyer;
    let ok = two_links(&joint("j", "revolute", "a", "b", "0 0 1"), "0.5");
    SpatialModel::from_urdf_str(&ok, free, None).unwrap();
    // the field the first error of a two-link robot with `joints` and b's mass names
    let field = |joints: &str, mass_b: &str| {
        field_of(SpatialModel::from_urdf_str(&two_links(joints, mass_b), free, None).unwrap_err())
    };
    let revolute = |xyz: &str| joint("j", "revolute", "a", "b", xyz);
    // a cycle: b's parent is a and a's parent is b
    let cycle =
        joint("j1", "revolute", "a", "b", "0 0 1") + &joint("j2", "revolute", "b", "a", "0 0 1");
    assert!(field(&cycle, "0.5").starts_with("joint[j"));
    let cases = [
        // a second parent
        (
            joint("j1", "revolute", "a", "b", "0 0 1") + &joint("j2", "fixed", "a", "b", "0 0 1"),
            "0.5",
            "joint[j2].child",
        ),
        (
            joint("j", "revolute", "nowhere", "b", "0 0 1"),
            "0.5",
            "joint[j].parent",
        ),
        (revolute("0 0 1"), "-0.5", "link[b].inertial.mass"),
        (revolute("0 0 1"), "NaN", "link[b].inertial.mass"),
        (revolute("0 NaN 1"), "0.5", "joint[j].origin.xyz"),
        (
            joint("j", "planar", "a", "b", "0 0 1"),
            "0.5",
            "joint[j].type",
        ),
    ];
    for (joints, mass_b, expected) in &cases {
        assert_eq!(
            field(joints, mass_b),
            *expected,
            "{joints} with mass {mass_b}"
        );
    }
    // a URDF with no link (a xacro left unexpanded) is refused by name, not by a panic
    assert_eq!(
        field_of(
            SpatialModel::from_urdf_str("<robot name=\"r\"></robot>", free, None).unwrap_err()
        ),
        "link"
    );
    // what `urdf-rs` refuses is named too: the text changed by `edit` in a good robot, and the
    // field that names the change
    let good = two_links(&joint("j", "revolute", "a", "b", "0 0 1"), "0.5");
    let malformed = [
        (("type=\"revolute\"", "type=\"bogus\""), "joint[j].type"),
        // commas, four angles, a number with two points (as in `pybullet_data`'s bicycle,
        // microtaur and biped2d)
        (
            ("xyz=\"0 0 1\"/><parent", "xyz=\"0, 0, 1\"/><parent"),
            "joint[j].origin.xyz",
        ),
        (
            ("<origin xyz", "<origin rpy=\"0 1.57 0 0\" xyz"),
            "joint[j].origin.rpy",
        ),
        (("lower=\"-1\"", "lower=\"-1.57.\""), "joint[j].limit.lower"),
        // an unexpanded xacro expression (husky)
        (
            ("<axis xyz=\"0 0 1\"", "<axis xyz=\"$(arg axis)\""),
            "joint[j].axis.xyz",
        ),
        (("velocity=\"1\"", ""), "joint[j].limit.velocity"),
        (("<parent link=\"a\"/>", ""), "joint[j].parent"),
        (("<mass value=\"0.5\"/>", ""), "link[b].inertial.mass"),
        (
            ("<mass value=\"0.5\"/>", "<mass value=\"half\"/>"),
            "link[b].inertial.mass",
        ),
        (
            ("iyz=\"0\" izz=\"0.1\"", "iyz=\"0\""),
            "link[b].inertial.inertia.izz",
        ),
    ];
    for ((from, to), expected) in malformed {
        assert!(good.contains(from), "{from}");
        let text = good.replacen(from, to, 1);
        let err = SpatialModel::from_urdf_str(&text, free, None).unwrap_err();
        assert_eq!(field_of(err.clone()), expected, "{text}: {err}");
    }
    // past URDF 1.2 a limit's velocity has a default (urdf-rs reads it so)
    let v12 = good.replacen("velocity=\"1\"", "", 1).replacen(
        "<robot name=\"r\"",
        "<robot name=\"r\" version=\"1.2\"",
        1,
    );
    SpatialModel::from_urdf_str(&v12, free, None).unwrap();
    assert!(
        matches!(BaseKind::from_name("sagittal").unwrap_err(), SpatialError::InvalidArgument { field, .. } if field == "base")
    );
}

#[test]
fn bad_state_names_the_field() {
    let model = quadruped();
    let mut data = SpatialData::new(&model);
    let mut q = neutral(&model);
    q[6] = 1.1;
    let err = kinematics::forward_kinematics(&model, &mut data, q.as_slice()).unwrap_err();
    assert!(
        matches!(err, SpatialError::NonUnitQuaternion { field: "q", .. }),
        "{err:?}"
    );
    let q = neutral(&model);
    let err = core_error(
        kinematics::forward_kinematics(&model, &mut data, &q.as_slice()[..18]).unwrap_err(),
    );
    let q_length = CoreError::WrongLength {
        field: "q",
        expected: 19,
        actual: 18,
    };
    assert_eq!(err, q_length);
    let mut v = vec![0.0; 18];
    v[4] = f64::NAN;
    let err =
        core_error(rigid_body::nonlinear_effects(&model, &mut data, q.as_slice(), &v).unwrap_err());
    assert!(
        matches!(
            err,
            CoreError::NonFinite {
                field: "v",
                index: 4,
                ..
            }
        ),
        "{err:?}"
    );
    let err = core_error(
        forward_dynamics(&model, &mut data, &[], q.as_slice(), &[0.0; 18], &[0.0; 17]).unwrap_err(),
    );
    assert!(
        matches!(err, CoreError::WrongLength { field: "tau", .. }),
        "{err:?}"
    );
    assert!(matches!(
        PointContact::new(&model, "no_such_foot", true).unwrap_err(),
        SpatialError::UnknownFrame { field, name } if field == "contacts[no_such_foot]" && name == "no_such_foot"
    ));
    assert!(matches!(
        model.frame_id("no_such_frame").unwrap_err(),
        SpatialError::UnknownFrame { field, .. } if field == "frame"
    ));
    assert!(
        matches!(kinematics::ReferenceFrame::from_name("body").unwrap_err(), SpatialError::InvalidArgument { field, .. } if field == "frame")
    );
}

/// A robot whose links' child joints are written out of name order: `base` carries `b_j`,
/// `a_j` (which carries `y_j`) and `c_j`, in that order in the file.
fn siblings_out_of_name_order(extra: &str) -> String {
    let link = |name: &str| {
        format!(
            r#"<link name="{name}"><inertial><mass value="1"/><inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>{extra}</link>"#
        )
    };
    let links: String = ["base", "zl", "al", "ml", "cl"].map(link).concat();
    let joints = joint("b_j", "revolute", "base", "zl", "1 0 0")
        + &joint("a_j", "revolute", "base", "al", "0 1 0")
        + &joint("y_j", "revolute", "al", "cl", "0 0 1")
        + &joint("c_j", "revolute", "base", "ml", "0 -1 0");
    format!(r#"<robot name="r">{links}{joints}</robot>"#)
}

#[test]
fn sibling_joints_are_ordered_by_name_as_urdfdom_orders_them() {
    // urdfdom keeps a link's child joints in a map by name, and Pinocchio walks the tree
    // depth first over them: a_j, its child y_j, then b_j, c_j (the file has b_j first)
    let model = SpatialModel::from_urdf_str(&siblings_out_of_name_order(""), BaseKind::Fixed, None)
        .unwrap();
    let names: Vec<&str> = model.joints.iter().map(|j| j.name.as_str()).collect();
    assert_eq!(names, ["a_j", "y_j", "b_j", "c_j"]);
    // and their coordinates in that order
    let idx: Vec<usize> = model.joints.iter().map(|j| j.idx_q).collect();
    assert_eq!(idx, [0, 1, 2, 3]);
}

#[test]
fn what_the_model_does_not_read_is_not_parsed() {
    // urdfdom's schema lets a texture go without a file name (robots exported from
    // urdfdom write `<texture />`); the looks and collision shapes are not the model's
    let looks = r#"<visual><geometry><mesh filename="m.stl"/></geometry><material name="grey"><texture /><color rgba="0.5 0.5 0.5 1"/></material></visual><collision><geometry><box size="1 1 1"/></geometry></collision>"#;
    let with = SpatialModel::from_urdf_str(
        &siblings_out_of_name_order(looks),
        BaseKind::FreeFlyer,
        None,
    )
    .unwrap();
    let without =
        SpatialModel::from_urdf_str(&siblings_out_of_name_order(""), BaseKind::FreeFlyer, None)
            .unwrap();
    assert_eq!(format!("{with:?}"), format!("{without:?}"));
    // malformed XML is still a parse error
    assert!(matches!(
        SpatialModel::from_urdf_str("<robot><link name=\"a\"></robot>", BaseKind::Fixed, None)
            .unwrap_err(),
        SpatialError::UrdfParse { .. }
    ));
}

#[test]
fn an_element_urdfdom_reads_once_is_read_from_its_first() {
    // urdfdom (Pinocchio's reader) takes a joint's first `axis`, `origin`, `limit`, a link's
    // first `inertial` and an inertial's first `mass` (Spirit 40 in `pybullet_data` gives a
    // joint two axes): the second of each changes nothing
    let first = siblings_out_of_name_order("");
    let second = first
        .replacen(
            r#"<axis xyz="0 1 0"/>"#,
            r#"<axis xyz="0 1 0"/><axis xyz="1 0 0"/><origin xyz="5 5 5"/>"#,
            1,
        )
        .replacen(
            r#"<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial>"#,
            r#"<inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/><mass value="7"/></inertial><inertial><mass value="9"/><inertia ixx="2" ixy="0" ixz="0" iyy="2" iyz="0" izz="2"/></inertial>"#,
            1,
        );
    assert_ne!(first, second);
    for base in [BaseKind::FreeFlyer, BaseKind::Fixed] {
        let with = SpatialModel::from_urdf_str(&second, base, None).unwrap();
        let without = SpatialModel::from_urdf_str(&first, base, None).unwrap();
        assert_eq!(format!("{with:?}"), format!("{without:?}"));
    }
}

#[test]
fn an_inertia_is_positive_semi_definite_to_round_off() {
    // b's rotational inertia with `ixy`, over a mass of 0.5 kg
    let robot = |ixy: &str, diagonal: &str| {
        let j = joint("j", "revolute", "a", "b", "0 0 1");
        two_links(&j, "0.5")
            .replace(
                r#"ixx="0.1" ixy="0""#,
                &format!(r#"ixx="{diagonal}" ixy="{ixy}""#),
            )
            .replace(
                r#"iyy="0.1" iyz="0" izz="0.1""#,
                &format!(r#"iyy="{diagonal}" iyz="0" izz="{diagonal}""#),
            )
    };
    let load = |ixy: &str, diagonal: &str| {
        SpatialModel::from_urdf_str(&robot(ixy, diagonal), BaseKind::FreeFlyer, None)
    };
    // |ixy| > ixx = iyy: an eigenvalue ixx − |ixy| < 0
    assert_eq!(
        field_of(load("0.2", "0.1").unwrap_err()),
        "link[b].inertial.inertia"
    );
    assert_eq!(
        field_of(load("-1e-9", "0").unwrap_err()),
        "link[b].inertial.inertia"
    );
    // a point mass written with round-off off the diagonal, and the edge of the cone
    load("1.35525e-20", "0").unwrap();
    load("0.1", "0.1").unwrap();
}

#[test]
fn an_added_frame_is_a_massless_fixed_link_at_the_same_origin() {
    use selfmanip_core::spatial::kinematics::{
        forward_kinematics, frame_jacobian, frame_placement,
    };
    // the quadruped's front-left foot with a toe 3 cm ahead and 1 cm down, turned: once as an
    // added frame, once as a massless link on a fixed joint written into the URDF
    let (xyz, rpy) = ([0.03, 0.0, -0.01], [0.1, -0.2, 0.3]);
    let mut added = quadruped();
    let id = added.add_frame("toe", "FL_foot", xyz, rpy).unwrap();
    assert_eq!(added.frames[id].kind, FrameKind::Operational);
    let toe_link = r#"<link name="toe"/><joint name="toe_joint" type="fixed"><origin xyz="0.03 0 -0.01" rpy="0.1 -0.2 0.3"/><parent link="FL_foot"/><child link="toe"/></joint></robot>"#;
    let urdf = std::fs::read_to_string(QUADRUPED)
        .unwrap()
        .replace("</robot>", toe_link);
    let written = SpatialModel::from_urdf_str(&urdf, BaseKind::FreeFlyer, None).unwrap();
    let mut rng = rng(3);
    for _ in 0..5 {
        let q = random_q(&added, &mut rng);
        let (mut a, mut w) = (SpatialData::new(&added), SpatialData::new(&written));
        forward_kinematics(&added, &mut a, q.as_slice()).unwrap();
        forward_kinematics(&written, &mut w, q.as_slice()).unwrap();
        let (fa, fw) = (id, written.frame_id("toe").unwrap());
        let (pa, pw) = (
            frame_placement(&added, &a, fa),
            frame_placement(&written, &w, fw),
        );
        assert!((pa.rotation - pw.rotation).amax() < 1e-15);
        assert!((pa.translation - pw.translation).amax() < 1e-15);
        for reference in [
            ReferenceFrame::World,
            ReferenceFrame::Local,
            ReferenceFrame::LocalWorldAligned,
        ] {
            frame_jacobian(&added, &mut a, fa, reference);
            frame_jacobian(&written, &mut w, fw, reference);
            assert!((&a.J - &w.J).amax() < 1e-14);
        }
    }
    // what is refused, by field
    let field = |name: &str, parent: &str, xyz: [f64; 3]| match quadruped()
        .add_frame(name, parent, xyz, [0.0; 3])
        .unwrap_err()
    {
        SpatialError::InvalidArgument { field, .. } | SpatialError::UnknownFrame { field, .. } => {
            field
        }
        other => panic!("{other:?}"),
    };
    assert_eq!(field("FL_foot", "trunk", [0.0; 3]), "frames[FL_foot]");
    assert_eq!(field("", "trunk", [0.0; 3]), "frames[]");
    assert_eq!(field("tip", "nowhere", [0.0; 3]), "frames[tip].parent");
    assert_eq!(
        field("tip", "trunk", [0.0, f64::NAN, 0.0]),
        "frames[tip].xyz_m"
    );
}

/// A URDF `floating` joint is a free flyer at its origin, as Pinocchio reads it: the quadruped
/// hung from a `world` link by a floating joint whose origin `g₀` is shifted and turned, on a
/// fixed base, is the quadruped on a free-flying base posed at `g₀ g(q)` — the same `M`, bias
/// forces, frame placements and constrained dynamics on four feet (the free flyer is the
/// root, so the same fast routes), at random states.
#[test]
fn a_floating_joint_is_a_free_flyer_at_its_origin() {
    let text = std::fs::read_to_string(QUADRUPED).unwrap();
    let (xyz, rpy) = ([0.3, -0.2, 0.5], [0.4, -0.3, 1.1]);
    let world = format!(
        r#"<link name="world"/><joint name="world_to_trunk" type="floating"><origin xyz="{} {} {}" rpy="{} {} {}"/><parent link="world"/><child link="trunk"/></joint></robot>"#,
        xyz[0], xyz[1], xyz[2], rpy[0], rpy[1], rpy[2]
    );
    let hung = text.replace("</robot>", &world);
    let floating = SpatialModel::from_urdf_str(&hung, BaseKind::Fixed, None).unwrap();
    let free = quadruped();
    assert_eq!((floating.nq, floating.nv), (free.nq, free.nv));
    assert_eq!(floating.joints[0].kind, JointKind::FreeFlyer);
    assert_eq!(floating.joints[0].name, "world_to_trunk");
    let g0 = SE3::from_xyz_rpy(xyz, rpy);
    let (mut d_floating, mut d_free) = (SpatialData::new(&floating), SpatialData::new(&free));
    let mut rng = rng(71);
    let mut worst = [0.0f64; 4];
    for _ in 0..10 {
        let (q, v, tau) = random_state(&floating, &mut rng);
        let mut q_free = q.clone();
        let r = nalgebra::UnitQuaternion::new_normalize(liegroup::quaternion_at(q.as_slice(), 3));
        let p = g0.act_point(&nalgebra::Vector3::new(q[0], q[1], q[2]));
        let r0 = nalgebra::UnitQuaternion::from_matrix(&g0.rotation);
        let turned = r0 * r;
        q_free.as_mut_slice()[..7]
            .copy_from_slice(&[p.x, p.y, p.z, turned.i, turned.j, turned.k, turned.w]);
        let contacts = |m: &SpatialModel| feet(m, [true; 4]);
        let (c_floating, c_free) = (contacts(&floating), contacts(&free));
        dynamics_at(&floating, &mut d_floating, &c_floating, (&q, &v, &tau)).unwrap();
        dynamics_at(&free, &mut d_free, &c_free, (&q_free, &v, &tau)).unwrap();
        worst[0] = worst[0].max((&d_floating.M - &d_free.M).amax());
        worst[1] = worst[1].max((&d_floating.h - &d_free.h).amax() / d_free.h.amax());
        worst[2] =
            worst[2].max((&d_floating.qdd - &d_free.qdd).amax() / d_free.qdd.amax().max(1.0));
        for name in FEET {
            let (a, b) = (
                floating.frame_id(name).unwrap(),
                free.frame_id(name).unwrap(),
            );
            let gap = kinematics::frame_placement(&floating, &d_floating, a)
                .max_abs_diff(&kinematics::frame_placement(&free, &d_free, b));
            worst[3] = worst[3].max(gap);
        }
        assert_eq!(d_floating.kkt_route, d_free.kkt_route);
    }
    assert_worst(
        "floating joint vs free-flying base:",
        &["M", "h", "q̈", "feet"],
        &worst,
        1e-12,
    );
}
