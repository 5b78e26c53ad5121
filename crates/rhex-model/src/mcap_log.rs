//! Leap logs as MCAP files that open in Foxglove (issue 5).
//!
//! Schema encoding `jsonschema`, message encoding `json`. Topics:
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/tf` | `foxglove.FrameTransforms` | `world` (z up, Foxglove's view) → `ned` (the thesis's x forward, z down: a half turn about x) → `body` (translation `(x, 0, z)`, pitch φ about +y) → `<pair>_hip` (hip offset, leg angle θ about −y) |
//! | `/scene` | `foxglove.SceneUpdate` | the body (a cube), the legs (line strips in their hip frames) and one arrow per active contact force (in `ned`, 0.005 m per N) |
//! | `/state` | `selfmanip.State` | `t_s` (relative to the front leg's start), `mode`, `q_names`, `q`, `qd` (thesis coordinates, NED) |
//! | `/contact_forces` | `selfmanip.ContactForces` | `t_s`, per contact: `name`, `active`, `point_m` `[x, z]`, `force_n` `[f_x, f_z]` (NED; ground on robot; null when inactive) |
//! | `/mode` | `selfmanip.Mode` | `t_s`, `mode`: the first sample and every change of contact mode |
//! | `/events` | `selfmanip.Event` | `t_s`, `kind`, `mode_before`, `mode_after`, `contacts`, `energy_loss_j` |
//!
//! Message log times are nanoseconds since the first sample (leap times can be negative when
//! the rear leg starts first); the `t_s` fields keep the leap clock. A metadata record
//! `selfmanip` holds the caller's key–value pairs (strategy, `t2`, parameters as JSON, …).
//!
//! The file is written to a temporary name in the target directory, flushed to disk and then
//! renamed: a crash never leaves a truncated file under the final name.
use crate::leap::{LeapEvent, Trajectory};
use crate::params::{LegShape, RhexParams};
use mcap::records::{MessageHeader, Metadata};
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;
use thiserror::Error;

/// Metres of arrow per newton of contact force on `/scene`.
pub const FORCE_ARROW_M_PER_N: f64 = 0.005;

#[derive(Debug, Error)]
pub enum McapLogError {
    #[error("MCAP log `{field}`: {reason}")]
    Invalid { field: String, reason: String },
    #[error("MCAP log I/O: {0}")]
    Io(#[from] std::io::Error),
    #[error("MCAP log: {0}")]
    Mcap(#[from] mcap::McapError),
}

/// What a log holds.
pub struct LeapLog<'a> {
    pub trajectory: &'a Trajectory,
    pub events: &'a [LeapEvent],
    pub params: &'a RhexParams,
    /// Written as the `selfmanip` metadata record.
    pub metadata: BTreeMap<String, String>,
}

fn invalid(field: &str, reason: String) -> McapLogError {
    McapLogError::Invalid {
        field: field.into(),
        reason,
    }
}

fn check(log: &LeapLog<'_>) -> Result<usize, McapLogError> {
    let tr = log.trajectory;
    let n = tr.t_s.len();
    let nq = log.params.pairs.len() + 3;
    for (field, len) in [
        ("q", tr.q.len()),
        ("qd", tr.qd.len()),
        ("mode", tr.mode.len()),
        ("contact_points_m", tr.contact_points_m.len()),
        ("contact_forces_n", tr.contact_forces_n.len()),
    ] {
        if len != n {
            return Err(invalid(field, format!("{len} samples, but t_s has {n}")));
        }
    }
    for k in 0..n {
        if !tr.t_s[k].is_finite() || (k > 0 && tr.t_s[k] < tr.t_s[k - 1]) {
            return Err(invalid(
                "t_s",
                format!("sample {k}: times must be finite and non-decreasing"),
            ));
        }
        if tr.q[k].len() != nq || tr.qd[k].len() != nq {
            return Err(invalid(
                "q",
                format!("sample {k}: expected {nq} coordinates"),
            ));
        }
        let nc = tr.contacts.len();
        if tr.contact_points_m[k].len() != nc || tr.contact_forces_n[k].len() != nc {
            return Err(invalid(
                "contact_forces_n",
                format!("sample {k}: expected {nc} contacts"),
            ));
        }
    }
    Ok(n)
}

fn stamp(t_ns: u64) -> Value {
    json!({"sec": t_ns / 1_000_000_000, "nsec": t_ns % 1_000_000_000})
}

/// Quaternion `[x, y, z, w]` of a rotation by `a` about `+y`.
fn about_y(a: f64) -> Value {
    json!({"x": 0.0, "y": (0.5 * a).sin(), "z": 0.0, "w": (0.5 * a).cos()})
}

fn tf(t: &Value, parent: &str, child: &str, xyz: [f64; 3], rot: Value) -> Value {
    json!({"timestamp": t, "parent_frame_id": parent, "child_frame_id": child,
           "translation": {"x": xyz[0], "y": xyz[1], "z": xyz[2]}, "rotation": rot})
}

fn color(r: f64, g: f64, b: f64) -> Value {
    json!({"r": r, "g": g, "b": b, "a": 1.0})
}

fn pose(xyz: [f64; 3], rot: Value) -> Value {
    json!({"position": {"x": xyz[0], "y": xyz[1], "z": xyz[2]}, "orientation": rot})
}

/// A scene entity with every array field present (Foxglove's JSON schema wants them).
fn entity(t: &Value, frame: &str, id: &str) -> serde_json::Map<String, Value> {
    let mut m = serde_json::Map::new();
    m.insert("timestamp".into(), t.clone());
    m.insert("frame_id".into(), frame.into());
    m.insert("id".into(), id.into());
    m.insert("lifetime".into(), json!({"sec": 0, "nsec": 0}));
    m.insert("frame_locked".into(), true.into());
    for k in [
        "metadata",
        "arrows",
        "cubes",
        "spheres",
        "cylinders",
        "lines",
        "triangles",
        "texts",
        "models",
    ] {
        m.insert(k.into(), json!([]));
    }
    m
}

/// Leg outline in its hip frame (x forward at θ = 0, z along the leg to the toe).
fn leg_points(shape: LegShape, rho: f64) -> Vec<Value> {
    let p = |x: f64, z: f64| json!({"x": x, "y": 0.0, "z": z});
    match shape {
        LegShape::Stick => vec![p(0.0, 0.0), p(0.0, rho)],
        LegShape::HalfCircle => (0..=16)
            .map(|i| {
                // outward normals (sin α, cos α), α from 0 (toe) to −π (hip)
                let a = -PI * i as f64 / 16.0;
                p(0.5 * rho * a.sin(), 0.5 * rho + 0.5 * rho * a.cos())
            })
            .collect(),
    }
}

const FOXGLOVE_TF_SCHEMA: &str = r#"{"title":"foxglove.FrameTransforms","type":"object","properties":{"transforms":{"type":"array","items":{"type":"object","properties":{"timestamp":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},"rotation":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}}}}}}"#;
const FOXGLOVE_SCENE_SCHEMA: &str = r#"{"title":"foxglove.SceneUpdate","type":"object","properties":{"deletions":{"type":"array"},"entities":{"type":"array"}}}"#;
const STATE_SCHEMA: &str = r#"{"title":"selfmanip.State","type":"object","properties":{"t_s":{"type":"number"},"mode":{"type":"string"},"q_names":{"type":"array","items":{"type":"string"}},"q":{"type":"array","items":{"type":"number"}},"qd":{"type":"array","items":{"type":"number"}}}}"#;
const FORCES_SCHEMA: &str = r#"{"title":"selfmanip.ContactForces","type":"object","properties":{"t_s":{"type":"number"},"contacts":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"active":{"type":"boolean"},"point_m":{"type":["array","null"]},"force_n":{"type":["array","null"]}}}}}}"#;
const MODE_SCHEMA: &str = r#"{"title":"selfmanip.Mode","type":"object","properties":{"t_s":{"type":"number"},"mode":{"type":"string"}}}"#;
const EVENT_SCHEMA: &str = r#"{"title":"selfmanip.Event","type":"object","properties":{"t_s":{"type":"number"},"kind":{"type":"string"},"mode_before":{"type":"string"},"mode_after":{"type":"string"},"contacts":{"type":"array","items":{"type":"string"}},"energy_loss_j":{"type":"number"}}}"#;

/// Coordinate names of a leap's `q`: `<pair>_theta` in body order, then `x`, `z`, `phi`.
pub fn q_names(params: &RhexParams) -> Vec<String> {
    let mut v: Vec<String> = params
        .ordered_pairs()
        .iter()
        .map(|p| format!("{}_theta", p.name()))
        .collect();
    v.extend(["x", "z", "phi"].map(String::from));
    v
}

/// Writes the MCAP stream of a leap to any seekable writer.
pub fn write_leap_mcap_to<W: Write + Seek>(w: W, log: &LeapLog<'_>) -> Result<W, McapLogError> {
    let n = check(log)?;
    let tr = log.trajectory;
    let params = log.params;
    let pairs = params.ordered_pairs();
    let names = q_names(params);
    let np = pairs.len();

    let mut out = mcap::Writer::new(w)?;
    let none = BTreeMap::new();
    let mut channel = |name: &str, schema: &str, topic: &str| -> Result<u16, McapLogError> {
        let sid = out.add_schema(name, "jsonschema", schema.as_bytes())?;
        Ok(out.add_channel(sid, topic, "json", &none)?)
    };
    let ch_tf = channel("foxglove.FrameTransforms", FOXGLOVE_TF_SCHEMA, "/tf")?;
    let ch_scene = channel("foxglove.SceneUpdate", FOXGLOVE_SCENE_SCHEMA, "/scene")?;
    let ch_state = channel("selfmanip.State", STATE_SCHEMA, "/state")?;
    let ch_forces = channel("selfmanip.ContactForces", FORCES_SCHEMA, "/contact_forces")?;
    let ch_mode = channel("selfmanip.Mode", MODE_SCHEMA, "/mode")?;
    let ch_event = channel("selfmanip.Event", EVENT_SCHEMA, "/events")?;
    out.write_metadata(&Metadata {
        name: "selfmanip".into(),
        metadata: log.metadata.clone(),
    })?;

    let t0 = tr.t_s.first().copied().unwrap_or(0.0);
    let ns = |t: f64| -> u64 { ((t - t0).max(0.0) * 1e9).round() as u64 };
    let mut seq = [0u32; 6];
    let mut put =
        |out: &mut mcap::Writer<W>, ch: u16, t_ns: u64, v: &Value| -> Result<(), McapLogError> {
            let s = &mut seq[ch as usize % 6];
            *s += 1;
            out.write_to_known_channel(
                &MessageHeader {
                    channel_id: ch,
                    sequence: *s,
                    log_time: t_ns,
                    publish_time: t_ns,
                },
                v.to_string().as_bytes(),
            )?;
            Ok(())
        };

    let body_len = params.l1 + params.l2 + 2.0 * params.rho_b;
    let body_centre = 0.5 * (params.l1 - params.l2);
    let mut events = log.events.iter().peekable();
    let mut last_mode: Option<&str> = None;
    for k in 0..n {
        let (t, q, qd) = (tr.t_s[k], &tr.q[k], &tr.qd[k]);
        let t_ns = ns(t);
        // events up to this sample, in time order
        while let Some(e) = events.peek() {
            if e.t_s > t {
                break;
            }
            let v = json!({"t_s": e.t_s, "kind": e.kind, "mode_before": e.mode_before,
                           "mode_after": e.mode_after, "contacts": e.contacts,
                           "energy_loss_j": e.energy_loss_j});
            put(&mut out, ch_event, ns(e.t_s), &v)?;
            events.next();
        }
        let ts = stamp(t_ns);
        // world (z up) -> ned (z down) -> body -> hips
        let (x, z, phi) = (q[np], q[np + 1], q[np + 2]);
        let mut tfs = vec![
            tf(
                &ts,
                "world",
                "ned",
                [0.0; 3],
                json!({"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0}),
            ),
            tf(&ts, "ned", "body", [x, 0.0, z], about_y(phi)),
        ];
        for (i, p) in pairs.iter().enumerate() {
            tfs.push(tf(
                &ts,
                "body",
                &format!("{}_hip", p.name()),
                [params.hip_x(*p), 0.0, 0.0],
                about_y(-q[i]),
            ));
        }
        put(&mut out, ch_tf, t_ns, &json!({ "transforms": tfs }))?;

        let mut ents = Vec::new();
        let mut body = entity(&ts, "body", "body");
        body["cubes"] = json!([{"pose": pose([body_centre, 0.0, 0.0], about_y(0.0)),
            "size": {"x": body_len, "y": 0.4, "z": 2.0 * params.rho_b}, "color": color(0.35, 0.45, 0.6)}]);
        ents.push(Value::Object(body));
        for p in &pairs {
            let frame = format!("{}_hip", p.name());
            let mut leg = entity(&ts, &frame, &format!("{}_leg", p.name()));
            leg["lines"] = json!([{"type": 0, "pose": pose([0.0; 3], about_y(0.0)), "thickness": 0.01,
                "scale_invariant": false, "points": leg_points(params.leg_shape, params.rho(*p)),
                "color": color(0.1, 0.1, 0.1), "colors": [], "indices": []}]);
            ents.push(Value::Object(leg));
        }
        let mut arrows = Vec::new();
        let mut contacts = Vec::new();
        for (c, name) in tr.contacts.iter().enumerate() {
            let (pt, f) = (tr.contact_points_m[k][c], tr.contact_forces_n[k][c]);
            contacts
                .push(json!({"name": name, "active": pt.is_some(), "point_m": pt, "force_n": f}));
            if let (Some(pt), Some(f)) = (pt, f) {
                let len = FORCE_ARROW_M_PER_N * f[0].hypot(f[1]);
                if len > 0.0 {
                    // +x of the arrow's pose turned onto (f_x, f_z): a rotation about +y by
                    // atan2(−f_z, f_x) maps x to (cos a, 0, −sin a)
                    arrows.push(
                        json!({"pose": pose([pt[0], 0.0, pt[1]], about_y((-f[1]).atan2(f[0]))),
                        "shaft_length": 0.8 * len, "shaft_diameter": 0.01, "head_length": 0.2 * len,
                        "head_diameter": 0.025, "color": color(0.85, 0.2, 0.1)}),
                    );
                }
            }
        }
        let mut forces = entity(&ts, "ned", "contact_forces");
        forces["arrows"] = Value::Array(arrows);
        forces["frame_locked"] = false.into();
        ents.push(Value::Object(forces));
        put(
            &mut out,
            ch_scene,
            t_ns,
            &json!({"deletions": [], "entities": ents}),
        )?;

        put(
            &mut out,
            ch_state,
            t_ns,
            &json!({"t_s": t, "mode": tr.mode[k], "q_names": names, "q": q, "qd": qd}),
        )?;
        put(
            &mut out,
            ch_forces,
            t_ns,
            &json!({"t_s": t, "contacts": contacts}),
        )?;
        if last_mode != Some(tr.mode[k].as_str()) {
            put(
                &mut out,
                ch_mode,
                t_ns,
                &json!({"t_s": t, "mode": tr.mode[k]}),
            )?;
            last_mode = Some(tr.mode[k].as_str());
        }
    }
    for e in events {
        let v = json!({"t_s": e.t_s, "kind": e.kind, "mode_before": e.mode_before,
                       "mode_after": e.mode_after, "contacts": e.contacts,
                       "energy_loss_j": e.energy_loss_j});
        put(&mut out, ch_event, ns(e.t_s), &v)?;
    }
    out.finish()?;
    Ok(out.into_inner())
}

/// Writes the log to `path` atomically (temporary file in the same directory, fsync,
/// rename).
pub fn write_leap_mcap(path: &Path, log: &LeapLog<'_>) -> Result<(), McapLogError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| invalid("path", format!("`{}` names no file", path.display())))?;
    let tmp = dir.join(format!(
        ".{}.{}.tmp",
        file_name.to_string_lossy(),
        std::process::id()
    ));
    let result = (|| -> Result<(), McapLogError> {
        let f = std::fs::File::create(&tmp)?;
        let mut w = write_leap_mcap_to(BufWriter::new(f), log)?;
        w.flush()?;
        let f = w
            .into_inner()
            .map_err(|e| McapLogError::Io(e.into_error()))?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)?;
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
