//! Named parameters: any field of a scenario — a behaviour parameter (`t2`), a field of the
//! robot description (`legs.front.links[0].length_m`), of the behaviour
//! (`behaviour.actuators.knee.gear_ratio`), of the terrain or of the options — set by a
//! *path*.
//!
//! **Syntax.** Keys separated by `.`, list elements by `[index]`; a key applied to a list
//! picks the element whose `name` (or, for joint programs, `joint`) is that key:
//! `robot.legs.front.links[0].length_m`, `behaviour.joints.front.phases.push.torque.command`.
//!
//! **Resolution.** A path starting with `robot`, `terrain`, `initial`, `behaviour` or
//! `options` is taken as it is. A bare name of a behaviour parameter is that parameter.
//! Otherwise the path is looked up under each of those roots: found under exactly one, it
//! names that field; under several, it is ambiguous; under none, unknown. Either is a
//! [`SimError::UnknownParameter`] naming the path.
use crate::error::SimError;
use serde_json::Value;

/// The roots of a scenario, in the order a bare path is looked up under them.
pub const ROOTS: [&str; 5] = ["robot", "behaviour", "options", "terrain", "initial"];

#[derive(Debug, Clone, PartialEq)]
enum Seg {
    Key(String),
    Index(usize),
}

fn parse(path: &str) -> Result<Vec<Seg>, String> {
    let mut segs = Vec::new();
    if path.is_empty() {
        return Err("empty path".into());
    }
    for part in path.split('.') {
        let (key, mut rest) = match part.find('[') {
            Some(i) => (&part[..i], &part[i..]),
            None => (part, ""),
        };
        if key.is_empty() && rest.is_empty() {
            return Err("empty key".into());
        }
        if !key.is_empty() {
            segs.push(Seg::Key(key.to_string()));
        }
        while !rest.is_empty() {
            let close = rest.find(']').ok_or("missing `]`")?;
            let idx: usize = rest[1..close]
                .trim()
                .parse()
                .map_err(|_| format!("bad index `{}`", &rest[1..close]))?;
            segs.push(Seg::Index(idx));
            rest = &rest[close + 1..];
            if !rest.is_empty() && !rest.starts_with('[') {
                return Err(format!("unexpected `{rest}`"));
            }
        }
    }
    Ok(segs)
}

fn element_named<'a>(list: &'a mut [Value], key: &str) -> Option<&'a mut Value> {
    list.iter_mut().find(|v| {
        ["name", "joint"]
            .iter()
            .any(|f| v.get(f).and_then(Value::as_str) == Some(key))
    })
}

fn lookup<'a>(mut v: &'a mut Value, segs: &[Seg]) -> Option<&'a mut Value> {
    for s in segs {
        v = match (s, v) {
            (Seg::Key(k), Value::Object(m)) => m.get_mut(k)?,
            (Seg::Key(k), Value::Array(a)) => element_named(a, k)?,
            (Seg::Index(i), Value::Array(a)) => a.get_mut(*i)?,
            _ => return None,
        };
    }
    Some(v)
}

/// The full path (under a root) that `name` resolves to in `scenario` (a scenario as a JSON
/// tree).
pub fn resolve(scenario: &Value, name: &str) -> Result<String, SimError> {
    let unknown = |reason: String| SimError::UnknownParameter {
        path: name.to_string(),
        reason,
    };
    let segs = parse(name).map_err(unknown)?;
    let mut tree = scenario.clone();
    if let Some(Seg::Key(first)) = segs.first() {
        if ROOTS.contains(&first.as_str()) {
            return match lookup(&mut tree, &segs) {
                Some(_) => Ok(name.to_string()),
                None => Err(unknown("no such field".into())),
            };
        }
    }
    if segs.len() == 1 {
        if let Some(Seg::Key(k)) = segs.first() {
            if scenario
                .get("behaviour")
                .and_then(|b| b.get("parameters"))
                .and_then(|p| p.get(k))
                .is_some()
            {
                return Ok(format!("behaviour.parameters.{k}"));
            }
        }
    }
    let found: Vec<String> = ROOTS
        .iter()
        .filter(|r| {
            let mut full = vec![Seg::Key(r.to_string())];
            full.extend(segs.iter().cloned());
            lookup(&mut tree, &full).is_some()
        })
        .map(|r| format!("{r}.{name}"))
        .collect();
    match found.len() {
        1 => Ok(found.into_iter().next().expect("one")),
        0 => Err(unknown(
            "not a behaviour parameter, nor a field of the robot, behaviour, options, terrain or \
             initial state"
                .into(),
        )),
        _ => Err(unknown(format!("ambiguous: {}", found.join(", ")))),
    }
}

/// Checks that every name of a point names a parameter of `tree`, and no two the same one
/// (`kp_push` and `parameters.kp_push`: the later value would run under both labels).
pub fn distinct_paths(tree: &Value, values: &[(String, Value)]) -> Result<(), SimError> {
    let mut seen: Vec<(String, &str)> = Vec::with_capacity(values.len());
    for (name, _) in values {
        let path = resolve(tree, name)?;
        if let Some((_, other)) = seen.iter().find(|(p, _)| *p == path) {
            return Err(SimError::InvalidValue {
                field: name.clone(),
                reason: format!("names the same parameter as `{other}` (`{path}`): give it once"),
            });
        }
        seen.push((path, name));
    }
    Ok(())
}

/// Sets the field `name` resolves to (see [`resolve`]) to `value`.
pub fn set(scenario: &mut Value, name: &str, value: Value) -> Result<String, SimError> {
    let full = resolve(scenario, name)?;
    let segs = parse(&full).expect("resolved paths parse");
    let slot = lookup(scenario, &segs).expect("resolved paths exist");
    *slot = value;
    Ok(full)
}

/// Every settable leaf of `tree` (numbers, strings, booleans, nulls), as full paths with
/// list elements by name where they have one.
pub fn leaves(tree: &Value) -> Vec<String> {
    fn walk(v: &Value, prefix: String, out: &mut Vec<String>) {
        match v {
            Value::Object(m) => {
                for (k, x) in m {
                    let p = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    walk(x, p, out);
                }
            }
            Value::Array(a) => {
                let numeric = a.iter().all(|x| x.is_number() || x.is_string());
                if numeric {
                    out.push(prefix);
                    return;
                }
                for (i, x) in a.iter().enumerate() {
                    let name = ["name", "joint"]
                        .iter()
                        .find_map(|f| x.get(f).and_then(Value::as_str));
                    let p = match name {
                        Some(n) if !n.contains('.') && !n.contains('[') => format!("{prefix}.{n}"),
                        _ => format!("{prefix}[{i}]"),
                    };
                    walk(x, p, out);
                }
            }
            _ => out.push(prefix),
        }
    }
    let mut out = Vec::new();
    walk(tree, String::new(), &mut out);
    out
}

/// The field names a struct's derived `Deserialize` reads, as it hands them to
/// `deserialize_struct`: serde's own list, including the optional fields a default value
/// leaves out of a serialization (nothing to keep in step by hand). Empty for a type that is
/// not read as a struct.
pub fn serde_field_names<T: serde::de::DeserializeOwned>() -> &'static [&'static str] {
    use serde::de::{self, Visitor};
    #[derive(Debug)]
    struct Caught(Option<&'static [&'static str]>);
    impl std::fmt::Display for Caught {
        fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
            f.write_str("field names caught")
        }
    }
    impl std::error::Error for Caught {}
    impl de::Error for Caught {
        fn custom<M: std::fmt::Display>(_: M) -> Self {
            Caught(None)
        }
    }
    struct Probe;
    impl<'de> de::Deserializer<'de> for Probe {
        type Error = Caught;
        fn deserialize_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, Caught> {
            Err(Caught(None))
        }
        fn deserialize_struct<V: Visitor<'de>>(
            self,
            _: &'static str,
            fields: &'static [&'static str],
            _: V,
        ) -> Result<V::Value, Caught> {
            Err(Caught(Some(fields)))
        }
        serde::forward_to_deserialize_any! {
            bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string bytes
            byte_buf option unit unit_struct newtype_struct seq tuple tuple_struct map enum
            identifier ignored_any
        }
    }
    match T::deserialize(Probe) {
        Err(Caught(Some(fields))) => fields,
        _ => &[],
    }
}

/// Deserializes the object `base` with the fields `overrides` set; on failure the field at
/// fault (the first override that fails on its own; `None` when only their combination
/// does) and serde's reason (that override's own, else the combination's).
pub fn deserialize_with<T: serde::de::DeserializeOwned>(
    base: &Value,
    overrides: &[(&String, &Value)],
) -> Result<T, (Option<String>, String)> {
    let with = |set: &[(&String, &Value)]| {
        let mut v = base.clone();
        for (k, val) in set {
            v[k.as_str()] = (*val).clone();
        }
        serde_json::from_value::<T>(v)
    };
    with(overrides).map_err(|e| {
        overrides
            .iter()
            .find_map(|o| {
                with(std::slice::from_ref(o))
                    .err()
                    .map(|e1| (Some(o.0.clone()), e1.to_string()))
            })
            .unwrap_or_else(|| (None, e.to_string()))
    })
}

/// Sorts named overrides into the records they set, for a caller whose parameters live in
/// several serde records (a preset's robot parameters, its configuration, its actuator):
/// `records[i]` lists the field names record `i` reads ([`serde_field_names`] or a part of
/// them); the first record that lists a name takes it. The overrides of each record, in their
/// order; `Err(name)`: the first name no record lists.
pub fn sort_by_record<'a>(
    records: &[&[&str]],
    overrides: &'a serde_json::Map<String, Value>,
) -> Result<Vec<Vec<(&'a String, &'a Value)>>, &'a str> {
    let mut out = vec![Vec::new(); records.len()];
    for (k, v) in overrides {
        let i = records
            .iter()
            .position(|names| names.contains(&k.as_str()))
            .ok_or(k.as_str())?;
        out[i].push((k, v));
    }
    Ok(out)
}

/// `base` with the fields `overrides` set, read with the same serde rules as the record read
/// from a file ([`deserialize_with`] on its serialization); `base` itself without overrides.
/// On failure the field at fault (`"overrides"` when only their combination is) and the
/// reason.
pub fn record_with<T: serde::Serialize + serde::de::DeserializeOwned + Clone>(
    base: &T,
    overrides: &[(&String, &Value)],
) -> Result<T, (String, String)> {
    if overrides.is_empty() {
        return Ok(base.clone());
    }
    let fault = |field: Option<String>, reason: String| {
        (field.unwrap_or_else(|| "overrides".into()), reason)
    };
    let tree = serde_json::to_value(base).map_err(|e| fault(None, e.to_string()))?;
    deserialize_with(&tree, overrides).map_err(|(field, reason)| fault(field, reason))
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    struct Gains {
        k_p: f64,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        k_d: Option<f64>,
        label: String,
    }

    /// The field names come from serde's own list, the optional field that its serialization
    /// leaves out included; a non-struct has none.
    #[test]
    fn serde_field_names_include_what_serialization_omits() {
        let base = Gains {
            k_p: 1.0,
            k_d: None,
            label: "a".into(),
        };
        let written = serde_json::to_value(&base).unwrap();
        assert!(written.get("k_d").is_none());
        assert_eq!(serde_field_names::<Gains>(), ["k_p", "k_d", "label"]);
        assert!(serde_field_names::<f64>().is_empty());
    }

    /// Overrides set fields by name; a failure names the override that fails on its own.
    #[test]
    fn deserialize_with_names_the_override_at_fault() {
        let base = serde_json::to_value(Gains {
            k_p: 1.0,
            k_d: None,
            label: "a".into(),
        })
        .unwrap();
        let (kd, lbl, kp) = ("k_d".to_string(), "label".to_string(), "k_p".to_string());
        let (two, name, text) = (json!(2.0), json!("b"), json!("fast"));
        let g: Gains = deserialize_with(&base, &[(&kd, &two), (&lbl, &name)]).unwrap();
        assert_eq!(
            g,
            Gains {
                k_p: 1.0,
                k_d: Some(2.0),
                label: "b".into()
            }
        );
        let e = deserialize_with::<Gains>(&base, &[(&kd, &two), (&kp, &text)]).unwrap_err();
        assert_eq!(e.0.as_deref(), Some("k_p"), "{e:?}");
        assert!(e.1.contains("invalid type"), "{e:?}");
    }

    /// Overrides go to the first record that reads their name, in their order; a name no
    /// record reads is returned; a record without overrides is its base.
    #[test]
    fn overrides_sort_into_records_and_merge() {
        let ov: serde_json::Map<String, Value> = [
            ("label", json!("b")),
            ("k_d", json!(3.0)),
            ("speed", json!(1.5)),
        ]
        .into_iter()
        .map(|(k, v)| (k.to_string(), v))
        .collect();
        let gains = serde_field_names::<Gains>();
        let sorted = sort_by_record(&[&["label"], gains, &["speed"]], &ov).unwrap();
        let names = |i: usize| {
            sorted[i]
                .iter()
                .map(|(k, _)| k.as_str())
                .collect::<Vec<_>>()
        };
        assert_eq!(
            (names(0), names(1), names(2)),
            (vec!["label"], vec!["k_d"], vec!["speed"])
        );
        assert_eq!(sort_by_record(&[gains], &ov).unwrap_err(), "speed");
        let base = Gains {
            k_p: 1.0,
            k_d: None,
            label: "a".into(),
        };
        let g = record_with(&base, &sorted[1]).unwrap();
        assert_eq!((g.k_p, g.k_d, g.label.as_str()), (1.0, Some(3.0), "a"));
        assert_eq!(record_with(&base, &[]).unwrap(), base);
        let (kp, text) = ("k_p".to_string(), json!("fast"));
        assert_eq!(record_with(&base, &[(&kp, &text)]).unwrap_err().0, "k_p");
    }

    #[test]
    fn paths_pick_fields_and_named_elements() {
        let mut s = json!({
            "robot": {"legs": [{"name": "front", "links": [{"length_m": 0.1}]},
                               {"name": "rear", "links": [{"length_m": 0.2}]}]},
            "behaviour": {"parameters": {"t2": 0.0}, "joints": [{"joint": "front", "phases": [{"name": "wait"}]}]},
            "options": {"t_final_s": 1.0},
        });
        assert_eq!(
            set(&mut s, "t2", json!(0.05)).unwrap(),
            "behaviour.parameters.t2"
        );
        assert_eq!(s["behaviour"]["parameters"]["t2"], json!(0.05));
        assert_eq!(
            set(&mut s, "legs.rear.links[0].length_m", json!(0.3)).unwrap(),
            "robot.legs.rear.links[0].length_m"
        );
        assert_eq!(s["robot"]["legs"][1]["links"][0]["length_m"], json!(0.3));
        assert_eq!(
            resolve(&s, "behaviour.joints.front.phases.wait.name").unwrap(),
            "behaviour.joints.front.phases.wait.name"
        );
        assert_eq!(resolve(&s, "t_final_s").unwrap(), "options.t_final_s");
        for bad in [
            "legs.middle.links[0].length_m",
            "robot.legs[5]",
            "nope",
            "a..b",
            "x[1",
        ] {
            match resolve(&s, bad) {
                Err(SimError::UnknownParameter { path, .. }) => assert_eq!(path, bad),
                other => panic!("{bad}: {other:?}"),
            }
        }
        assert!(leaves(&s).contains(&"robot.legs.front.links[0].length_m".to_string()));
    }
}
