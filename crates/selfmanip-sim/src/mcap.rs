//! Execution logs as MCAP files that open in Foxglove, for any robot.
//!
//! Schema encoding `jsonschema`, message encoding `json`. Topics:
//!
//! | topic | schema | content |
//! |---|---|---|
//! | `/tf` | `foxglove.FrameTransforms` | `world` (z up, Foxglove's view) → `ned` (x forward, z down: a half turn about x) → `body` (translation `(x, 0, z)`, pitch φ about +y) → one frame per link, at its joint (the first link of a leg at its hip, in `body`; each next one at the end of the previous link, in its frame), turned by `s θ` about +y |
//! | `/scene` | `foxglove.SceneUpdate` | the body (a box spanning its hips and body contacts), each link (a line along its length), each contact shape (arcs and circles as lines, points as spheres) in the frame of its part, and one arrow per active contact force (in `ned`, [`FORCE_ARROW_M_PER_N`] m per N) |
//! | `/state` | `selfmanip.State` | `t_s`, `mode`, `q_names`, `q`, `qd` (NED), and `tau` when sampled |
//! | `/contact_forces` | `selfmanip.ContactForces` | `t_s`, per contact: `name`, `active`, `point_m` `[x, z]`, `force_n` `[f_x, f_z]` (NED; ground on robot; null when inactive) |
//! | `/mode` | `selfmanip.Mode` | `t_s`, `mode`: the first sample and every change of contact mode |
//! | `/events` | `selfmanip.Event` | `t_s`, `kind`, `mode_before`, `mode_after`, `contacts`, `energy_loss_j`, and per contact (the order of `/contact_forces`) `impulse_n_s` and `force_n` `[x, z]` (NED; ground on robot; null where none: [`EventRecord`]; left out for a record without them) |
//!
//! Message log times are nanoseconds since the first sample (sample times may be negative);
//! the `t_s` fields keep the caller's clock. A metadata record `selfmanip` holds the caller's
//! key–value pairs.
//!
//! The file is written to a temporary name in the target directory, flushed to disk and then
//! renamed: a crash never leaves a truncated file under the final name. The temporary name,
//! `.<name>.<pid>.tmp`, is hidden and says whose it is: a write that was killed (SIGKILL)
//! leaves it behind, and the next write of the same file removes it once that process is gone.
use crate::error::SimError;
use crate::events::EventRecord;
use crate::trajectory::Trajectory;
use mcap::records::{MessageHeader, Metadata};
use selfmanip_core::model::ContactShape;
use selfmanip_core::Model;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use std::io::{BufWriter, Seek, Write};
use std::path::Path;

/// Metres of arrow per newton of contact force on `/scene`.
pub const FORCE_ARROW_M_PER_N: f64 = 0.005;

/// How the robot is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// The frame of each link (by joint), children of `body` or of the previous link.
    pub link_frames: Vec<String>,
    /// The body box: centre `(x, z)` in the body frame, length (x), height (z), width (y).
    pub body_centre_m: [f64; 2],
    pub body_size_m: [f64; 3],
}

impl Layout {
    /// Frames `<leg>_link<k>`; the body box spans the hips and the body's contact sites.
    pub fn of(model: &Model) -> Self {
        let link_frames = model
            .joints
            .iter()
            .map(|j| format!("{}_link{}", model.legs[j.leg].name, j.index_in_leg))
            .collect();
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        let mut grow = |p: [f64; 2], r: f64| {
            for i in 0..2 {
                lo[i] = lo[i].min(p[i] - r);
                hi[i] = hi[i].max(p[i] + r);
            }
        };
        for leg in &model.legs {
            grow([leg.hip_m.x, leg.hip_m.y], 0.0);
        }
        for c in model.contacts.iter().filter(|c| c.link.is_none()) {
            match c.shape {
                ContactShape::Point { position_m } => grow([position_m.x, position_m.y], 0.0),
                ContactShape::Arc {
                    center_m, radius_m, ..
                } => grow([center_m.x, center_m.y], radius_m),
            }
        }
        if !lo[0].is_finite() {
            lo = [-0.1, -0.05];
            hi = [0.1, 0.05];
        }
        let length = (hi[0] - lo[0]).max(0.02);
        let height = (hi[1] - lo[1]).max(0.02);
        Layout {
            link_frames,
            body_centre_m: [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])],
            body_size_m: [length, height, 0.4],
        }
    }
}

/// What a log holds.
pub struct McapLog<'a> {
    pub model: &'a Model,
    pub trajectory: &'a Trajectory,
    pub events: &'a [EventRecord],
    /// Written as the `selfmanip` metadata record.
    pub metadata: BTreeMap<String, String>,
    pub layout: Layout,
}

fn invalid(field: &str, reason: String) -> SimError {
    SimError::InvalidValue {
        field: field.into(),
        reason,
    }
}

fn mcap_err(e: mcap::McapError) -> SimError {
    SimError::Mcap {
        message: e.to_string(),
    }
}

fn io_err(path: &Path) -> impl Fn(std::io::Error) -> SimError + '_ {
    move |e| SimError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
        kind: e.kind(),
    }
}

fn check(log: &McapLog<'_>) -> Result<usize, SimError> {
    let tr = log.trajectory;
    let n = tr.t_s.len();
    let nq = log.model.nq();
    if log.layout.link_frames.len() != log.model.n_joints() {
        return Err(invalid(
            "layout.link_frames",
            format!("expected {} frames, one per link", log.model.n_joints()),
        ));
    }
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
    if !tr.tau.is_empty() && tr.tau.len() != n {
        return Err(invalid(
            "tau",
            format!("{} samples, but t_s has {n}", tr.tau.len()),
        ));
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
    for (i, e) in log.events.iter().enumerate() {
        if !e.t_s.is_finite() {
            return Err(invalid(
                &format!("events[{i}].t_s"),
                "must be finite".into(),
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

fn line(points: Vec<Value>, rgb: [f64; 3]) -> Value {
    json!({"type": 0, "pose": pose([0.0; 3], about_y(0.0)), "thickness": 0.01,
           "scale_invariant": false, "points": points,
           "color": color(rgb[0], rgb[1], rgb[2]), "colors": [], "indices": []})
}

/// A contact shape as lines (arcs, circles) or a sphere (points), in its part's frame.
fn shape_entity(ent: &mut serde_json::Map<String, Value>, shape: &ContactShape) {
    let p = |x: f64, z: f64| json!({"x": x, "y": 0.0, "z": z});
    match *shape {
        ContactShape::Point { position_m } => {
            ent["spheres"] = json!([{"pose": pose([position_m.x, 0.0, position_m.y], about_y(0.0)),
                "size": {"x": 0.02, "y": 0.02, "z": 0.02}, "color": color(0.1, 0.1, 0.1)}]);
        }
        ContactShape::Arc {
            center_m,
            radius_m,
            normal_range_rad,
        } => {
            let [a0, a1] = normal_range_rad.unwrap_or([0.0, std::f64::consts::TAU]);
            // outward normals (sin α, cos α) in the part's frame
            let pts = (0..=32)
                .map(|i| {
                    let a = a0 + (a1 - a0) * i as f64 / 32.0;
                    p(
                        center_m.x + radius_m * a.sin(),
                        center_m.y + radius_m * a.cos(),
                    )
                })
                .collect();
            ent["lines"] = json!([line(pts, [0.1, 0.1, 0.1])]);
        }
    }
}

const FOXGLOVE_TF_SCHEMA: &str = r#"{"title":"foxglove.FrameTransforms","type":"object","properties":{"transforms":{"type":"array","items":{"type":"object","properties":{"timestamp":{"type":"object","properties":{"sec":{"type":"integer"},"nsec":{"type":"integer"}}},"parent_frame_id":{"type":"string"},"child_frame_id":{"type":"string"},"translation":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"}}},"rotation":{"type":"object","properties":{"x":{"type":"number"},"y":{"type":"number"},"z":{"type":"number"},"w":{"type":"number"}}}}}}}}"#;
const FOXGLOVE_SCENE_SCHEMA: &str = r#"{"title":"foxglove.SceneUpdate","type":"object","properties":{"deletions":{"type":"array"},"entities":{"type":"array"}}}"#;
const STATE_SCHEMA: &str = r#"{"title":"selfmanip.State","type":"object","properties":{"t_s":{"type":"number"},"mode":{"type":"string"},"q_names":{"type":"array","items":{"type":"string"}},"q":{"type":"array","items":{"type":"number"}},"qd":{"type":"array","items":{"type":"number"}},"tau":{"type":"array","items":{"type":"number"}}}}"#;
const FORCES_SCHEMA: &str = r#"{"title":"selfmanip.ContactForces","type":"object","properties":{"t_s":{"type":"number"},"contacts":{"type":"array","items":{"type":"object","properties":{"name":{"type":"string"},"active":{"type":"boolean"},"point_m":{"type":["array","null"]},"force_n":{"type":["array","null"]}}}}}}"#;
const MODE_SCHEMA: &str = r#"{"title":"selfmanip.Mode","type":"object","properties":{"t_s":{"type":"number"},"mode":{"type":"string"}}}"#;
const EVENT_SCHEMA: &str = r#"{"title":"selfmanip.Event","type":"object","properties":{"t_s":{"type":"number"},"kind":{"type":"string"},"mode_before":{"type":"string"},"mode_after":{"type":"string"},"contacts":{"type":"array","items":{"type":"string"}},"energy_loss_j":{"type":"number"},"impulse_n_s":{"type":"array","items":{"type":["array","null"]}},"force_n":{"type":"array","items":{"type":["array","null"]}}}}"#;

fn event_json(e: &EventRecord) -> Value {
    let mut v = json!({"t_s": e.t_s, "kind": e.kind, "mode_before": e.mode_before,
           "mode_after": e.mode_after, "contacts": e.contacts,
           "energy_loss_j": e.energy_loss_j});
    // per-site vectors when the record has them (a synthetic event may have none)
    for (key, sites) in [("impulse_n_s", &e.impulse_n_s), ("force_n", &e.force_n)] {
        if !sites.is_empty() {
            v[key] = json!(sites);
        }
    }
    v
}

/// Writes the MCAP stream of a log to any seekable writer.
pub fn write_mcap_to<W: Write + Seek>(w: W, log: &McapLog<'_>) -> Result<W, SimError> {
    write_mcap_to_until(w, log, &|| false)
}

/// The error of a write that `cancelled` stopped (Ctrl-C): an I/O error of kind
/// `Interrupted` naming the file.
fn interrupted(path: &str) -> SimError {
    SimError::Io {
        path: path.into(),
        message: "the write was interrupted".into(),
        kind: std::io::ErrorKind::Interrupted,
    }
}

/// [`write_mcap_to`], asking `cancelled` before each sample and stopping with an
/// `Interrupted` error once it says yes.
pub fn write_mcap_to_until<W: Write + Seek>(
    w: W,
    log: &McapLog<'_>,
    cancelled: &dyn Fn() -> bool,
) -> Result<W, SimError> {
    let n = check(log)?;
    let (tr, model, layout) = (log.trajectory, log.model, &log.layout);
    let nj = model.n_joints();

    let mut out = mcap::Writer::new(w).map_err(mcap_err)?;
    let none = BTreeMap::new();
    let mut channel = |name: &str, schema: &str, topic: &str| -> Result<u16, SimError> {
        let sid = out
            .add_schema(name, "jsonschema", schema.as_bytes())
            .map_err(mcap_err)?;
        out.add_channel(sid, topic, "json", &none).map_err(mcap_err)
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
    })
    .map_err(mcap_err)?;

    let t0 = tr.t_s.first().copied().unwrap_or(0.0);
    let ns = |t: f64| -> u64 { ((t - t0).max(0.0) * 1e9).round() as u64 };
    let mut seq = [0u32; 6];
    let mut put =
        |out: &mut mcap::Writer<W>, ch: u16, t_ns: u64, v: &Value| -> Result<(), SimError> {
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
            )
            .map_err(mcap_err)
        };

    // the parent frame of each link: the body for a leg's first link, else the previous link
    let parent: Vec<&str> = model
        .joints
        .iter()
        .enumerate()
        .map(|(j, joint)| {
            if joint.index_in_leg == 0 {
                "body"
            } else {
                layout.link_frames[j - 1].as_str()
            }
        })
        .collect();
    let mut events = log.events.iter().peekable();
    let mut last_mode: Option<&str> = None;
    for k in 0..n {
        if cancelled() {
            return Err(interrupted(""));
        }
        let (t, q, qd) = (tr.t_s[k], &tr.q[k], &tr.qd[k]);
        let t_ns = ns(t);
        // events up to this sample, in time order
        while let Some(e) = events.peek() {
            if e.t_s > t {
                break;
            }
            put(&mut out, ch_event, ns(e.t_s), &event_json(e))?;
            events.next();
        }
        let ts = stamp(t_ns);
        // world (z up) -> ned (z down) -> body -> links
        let (x, z, phi) = (q[nj], q[nj + 1], q[nj + 2]);
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
        for (j, joint) in model.joints.iter().enumerate() {
            let origin = if joint.index_in_leg == 0 {
                let hip = model.legs[joint.leg].hip_m;
                [hip.x, 0.0, hip.y]
            } else {
                [0.0, 0.0, model.joints[j - 1].length_m]
            };
            tfs.push(tf(
                &ts,
                parent[j],
                &layout.link_frames[j],
                origin,
                about_y(joint.axis_sign * q[j]),
            ));
        }
        put(&mut out, ch_tf, t_ns, &json!({ "transforms": tfs }))?;

        let mut ents = Vec::new();
        let mut body = entity(&ts, "body", "body");
        let [cx, cz] = layout.body_centre_m;
        let [lx, lz, ly] = layout.body_size_m;
        body["cubes"] = json!([{"pose": pose([cx, 0.0, cz], about_y(0.0)),
            "size": {"x": lx, "y": ly, "z": lz}, "color": color(0.35, 0.45, 0.6)}]);
        ents.push(Value::Object(body));
        for (j, joint) in model.joints.iter().enumerate() {
            let frame = &layout.link_frames[j];
            let mut link = entity(&ts, frame, frame);
            let p = |z: f64| json!({"x": 0.0, "y": 0.0, "z": z});
            link["lines"] = json!([line(vec![p(0.0), p(joint.length_m)], [0.25, 0.25, 0.25])]);
            ents.push(Value::Object(link));
        }
        for c in &model.contacts {
            let frame = match c.link {
                None => "body",
                Some(j) => layout.link_frames[j].as_str(),
            };
            let mut ent = entity(&ts, frame, &format!("contact_{}", c.name));
            shape_entity(&mut ent, &c.shape);
            ents.push(Value::Object(ent));
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

        let mut state =
            json!({"t_s": t, "mode": tr.mode[k], "q_names": tr.q_names, "q": q, "qd": qd});
        if let Some(tau) = tr.tau.get(k) {
            state["tau"] = json!(tau);
        }
        put(&mut out, ch_state, t_ns, &state)?;
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
        put(&mut out, ch_event, ns(e.t_s), &event_json(e))?;
    }
    out.finish().map_err(mcap_err)?;
    Ok(out.into_inner())
}

/// The temporary name a write of `file_name` by process `pid` uses beside it.
fn temp_name(file_name: &str, pid: u32) -> String {
    format!(".{file_name}.{pid}.tmp")
}

/// Removes from `dir` the temporary files of earlier writes of `file_name` whose process is
/// gone (killed mid-write: nothing else removed them). A process that still runs — another
/// write of the same file — keeps its own. Where processes cannot be looked up (no `/proc`),
/// nothing is removed.
fn remove_stale_temp_files(dir: &Path, file_name: &str) {
    let proc_dir = Path::new("/proc");
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    if !proc_dir.is_dir() {
        return;
    }
    let prefix = format!(".{file_name}.");
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(pid) = name
            .to_str()
            .and_then(|n| n.strip_prefix(&prefix))
            .and_then(|n| n.strip_suffix(".tmp"))
            .and_then(|p| p.parse::<u32>().ok())
        else {
            continue;
        };
        if pid != std::process::id() && !proc_dir.join(pid.to_string()).exists() {
            let _ = std::fs::remove_file(entry.path());
        }
    }
}

/// Writes the log to `path` atomically (temporary file in the same directory, fsync,
/// rename).
pub fn write_mcap(path: &Path, log: &McapLog<'_>) -> Result<(), SimError> {
    write_mcap_until(path, log, &|| false)
}

/// [`write_mcap`], stopped by `cancelled` (asked before each sample): an interrupted write
/// removes its temporary file and leaves `path` as it was.
pub fn write_mcap_until(
    path: &Path,
    log: &McapLog<'_>,
    cancelled: &dyn Fn() -> bool,
) -> Result<(), SimError> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => std::path::PathBuf::from("."),
    };
    let file_name = path
        .file_name()
        .ok_or_else(|| invalid("path", format!("`{}` names no file", path.display())))?;
    let tmp = dir.join(temp_name(&file_name.to_string_lossy(), std::process::id()));
    remove_stale_temp_files(&dir, &file_name.to_string_lossy());
    let result = (|| -> Result<(), SimError> {
        let f = std::fs::File::create(&tmp).map_err(io_err(path))?;
        let mut w =
            write_mcap_to_until(BufWriter::new(f), log, cancelled).map_err(|e| match e {
                SimError::Io {
                    kind: std::io::ErrorKind::Interrupted,
                    ..
                } => interrupted(&path.display().to_string()),
                e => e,
            })?;
        w.flush().map_err(io_err(path))?;
        let f = w.into_inner().map_err(|e| io_err(path)(e.into_error()))?;
        f.sync_all().map_err(io_err(path))?;
        std::fs::rename(&tmp, path).map_err(io_err(path))?;
        Ok(())
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pid of a process that has ended (a child, waited for).
    fn ended_pid() -> u32 {
        let mut child = std::process::Command::new("true").spawn().unwrap();
        let pid = child.id();
        child.wait().unwrap();
        pid
    }

    #[test]
    fn a_killed_writers_temp_file_is_removed_by_the_next_write_and_a_live_ones_kept() {
        if !Path::new("/proc").is_dir() {
            return; // processes cannot be looked up: nothing is removed (the doc's rule)
        }
        let dir = std::env::temp_dir().join(format!("selfmanip-stale-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let dead = temp_name("run.mcap", ended_pid());
        let live = temp_name("run.mcap", 1); // init runs as long as the system does
        let other = temp_name("other.mcap", ended_pid());
        for name in [&dead, &live, &other, &"run.mcap".to_string()] {
            std::fs::write(dir.join(name), b"x").unwrap();
        }
        remove_stale_temp_files(&dir, "run.mcap");
        let mut left: Vec<String> = std::fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        left.sort();
        let mut want = vec![live, other, "run.mcap".to_string()];
        want.sort();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(left, want);
    }
}
