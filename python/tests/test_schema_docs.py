"""The field tables of docs/robot-description.md and docs/behaviours.md against the Rust types
they describe (issue 30, item 7): a field added to the types without a line in the docs, a
field documented that the types do not have, a wrong "required" or a wrong default fails.

The independent route is the engine's own deserializer: every struct of both schemas denies
unknown fields, so an unknown key at a place makes serde list the struct's fields ("unknown
field `__probe__`, expected one of ..."), and an unknown ``kind`` lists an enum's variants.
A field is required when leaving it out of a minimal input is "missing field"; a documented
default is right when giving it explicitly changes nothing in the engine's own dump of the
input (``Robot.to_dict``, ``Scenario.to_dict``) against leaving it out.
"""

from __future__ import annotations

import copy
import json
import pathlib
import re
from typing import Any

import pytest

import selfmanip
from selfmanip.errors import InvalidInputError
from selfmanip.simulation import scenario

DOCS = pathlib.Path(__file__).resolve().parents[2] / "docs"
PROBE = "__probe__"

ROBOT = {"name": "r", "body": {"mass_kg": 1.0, "inertia_kg_m2": 0.1, "collision": [
            {"shape": {"kind": "circle", "radius_m": 0.01}, "friction": {"kind": "sliding"}}]},
         "legs": [{"name": "leg", "hip_m": [0.0, 0.0], "links": [{"length_m": 0.1}]}],
         "contacts": [{"name": "foot", "leg": "leg", "shape": {"kind": "point", "position_m": [0.0, 0.1]},
                       "friction": {"kind": "sliding"}}]}
PHASE = ["joints", 0, "phases", 0]
BEHAVIOUR = {"joints": [{"joint": "leg", "phases": [{"name": "a"}]}]}

#: Each documented struct: its family, where it sits in a valid top-level input, and a
#: minimal content (its required fields; the ``kind`` of a tagged variant).
SCHEMAS: dict[str, tuple[str, list[Any], dict[str, Any]]] = {
    "robot": ("robot", [], {"name": "r", "body": {"mass_kg": 1.0, "inertia_kg_m2": 0.1}}),
    "robot.body": ("robot", ["body"], {"mass_kg": 1.0, "inertia_kg_m2": 0.1}),
    "robot.legs[]": ("robot", ["legs", 0], {"name": "leg", "hip_m": [0.0, 0.0], "links": [{"length_m": 0.1}]}),
    "robot.legs[].links[]": ("robot", ["legs", 0, "links", 0], {"length_m": 0.1}),
    "robot.legs[].links[].spring": ("robot", ["legs", 0, "links", 0, "spring"], {"stiffness_n_m_per_rad": 1.0}),
    "robot.contacts[]": ("robot", ["contacts", 0], {"name": "foot", "shape": {"kind": "point", "position_m": [0, 0]},
                                                    "friction": {"kind": "sliding"}}),
    "robot.contacts[].shape kind=point": ("robot", ["contacts", 0, "shape"], {"kind": "point", "position_m": [0, 0.1]}),
    "robot.contacts[].shape kind=circle": ("robot", ["contacts", 0, "shape"],
                                           {"kind": "circle", "center_m": [0, 0.1], "radius_m": 0.02}),
    "robot.contacts[].shape kind=arc": ("robot", ["contacts", 0, "shape"],
                                        {"kind": "arc", "center_m": [0, 0.05], "radius_m": 0.05,
                                         "normal_range_rad": [-3.0, 0.0]}),
    "robot.body.collision[]": ("robot", ["body", "collision", 0], {"shape": {"kind": "circle", "radius_m": 0.1},
                                                                 "friction": {"kind": "sliding"}}),
    **{f"robot.body.collision[].shape kind={k}": ("robot", ["body", "collision", 0, "shape"], dict(kind=k, **m))
       for k, m in (("box", {"size_m": [0.1, 0.05]}), ("stadium", {"length_m": 0.1, "radius_m": 0.02}),
                    ("circle", {"radius_m": 0.02}))},
    "robot.contacts[].friction kind=sticking": ("robot", ["contacts", 0, "friction"], {"kind": "sticking"}),
    "robot.contacts[].friction kind=sliding": ("robot", ["contacts", 0, "friction"], {"kind": "sliding"}),
    "behaviour": ("behaviour", [], {}),
    "behaviour.free_joints": ("behaviour", ["free_joints"], {"kp_per_s2": 400.0, "kd_per_s": 40.0}),
    "behaviour.actuators.* kind=saturated": ("behaviour", ["actuators", "a"],
                                             {"kind": "saturated", "max_torque_n_m": 1.0}),
    "behaviour.actuators.* kind=dc_motor": ("behaviour", ["actuators", "a"],
                                            {"kind": "dc_motor", "motor": "x-rhex", "gearbox": "x-rhex-28"}),
    "behaviour.events.*": ("behaviour", ["events", "e"], {"on": "flight"}),
    "behaviour.joints[]": ("behaviour", ["joints", 0], {"joint": "leg", "phases": [{"name": "a"}]}),
    "behaviour.joints[].phases[]": ("behaviour", PHASE, {"name": "a"}),
    "behaviour.joints[].phases[].start": ("behaviour", PHASE + ["start"], {}),
    **{f"behaviour.joints[].phases[].torque kind={k}": ("behaviour", PHASE + ["torque"], dict(kind=k, **m))
       for k, m in (("zero", {}), ("constant", {"torque_n_m": 1.0}),
                    ("schedule", {"times_s": [0.0, 1.0], "torques_n_m": [0.0, 1.0]}),
                    ("servo", {"kp_n_m_per_rad": 1.0, "kd_n_m_s_per_rad": 0.1}),
                    ("motor", {"actuator": "a", "command": 1.0}))},
    **{f"behaviour.joints[].phases[].motion kind={k}": ("behaviour", PHASE + ["motion"], dict(kind=k, **m))
       for k, m in (("hold", {"angle_rad": 0.0}),
                    ("swing", {"target_rad": 1.0, "speed_rad_s": 1.0, "accel_rad_s2": 10.0}),
                    ("park", {"target_rad": 1.0, "accel_rad_s2": 10.0}))},
}

#: The value lists (unit enums) documented with ``<!-- values: ... -->``: where a value sits.
VALUES = {"behaviour.on": ("behaviour", PHASE + ["start", "on"])}


def doc_tables(doc: str, marker: str) -> dict[str, list[list[str]]]:
    """``{id: rows}`` of every table after ``<!-- marker: id -->`` (cells stripped)."""
    text = (DOCS / doc).read_text(encoding="utf-8")
    out = {}
    for m in re.finditer(rf"<!-- {marker}: (.+?) -->\n((?:\|.*\n?)+)", text):
        rows = [[c.strip() for c in line.strip().strip("|").split("|")] for line in m.group(2).splitlines()]
        out[m.group(1)] = rows[2:]
    return out


def documented() -> dict[str, list[list[str]]]:
    return {**doc_tables("robot-description.md", "schema"), **doc_tables("behaviours.md", "schema")}


def put(top: Any, path: list[Any], value: Any) -> Any:
    top = copy.deepcopy(top)
    if not path:
        return value
    node = top
    for k in path[:-1]:
        node = node.setdefault(k, {}) if isinstance(k, str) else node[k]
    node[path[-1]] = value
    return top


def get(top: Any, path: list[Any]) -> Any:
    for k in path:
        top = top[k]
    return top


def dump(family: str, top: dict[str, Any]) -> dict[str, Any]:
    """The engine's own dump of a top-level input (defaults filled in), or the parse error."""
    if family == "robot":
        return selfmanip.Robot.from_dict(top).to_dict()
    return scenario(ROBOT, top, [0.0] * 4).to_dict()["behaviour"]


def parse_error(family: str, top: dict[str, Any]) -> str:
    with pytest.raises(InvalidInputError) as e:
        dump(family, top)
    return str(e.value)


def listed(message: str, what: str) -> list[str]:
    """The names serde lists after "unknown <what> `__probe__`, expected ..." (none: [])."""
    m = re.search(rf"unknown {what} `{PROBE}`, (?:expected (.*?)(?: at line|$)|there are no fields)", message)
    assert m, message
    return re.findall(r"`([^`]+)`", m.group(1) or "")


def rust_fields(schema: str) -> list[str]:
    family, path, minimal = SCHEMAS[schema]
    base = ROBOT if family == "robot" else BEHAVIOUR
    top = put(base, path, {**minimal, PROBE: 1})
    if "kind" in minimal and not (set(minimal) - {"kind"}) and _parses(family, top):
        return []            # a variant without fields: serde ignores the rest of the table
    return listed(parse_error(family, top), "field")


def _parses(family: str, top: dict[str, Any]) -> bool:
    try:
        dump(family, top)
        return True
    except InvalidInputError:
        return False


DOCUMENTED = documented()


def test_every_struct_is_documented() -> None:
    assert set(DOCUMENTED) == set(SCHEMAS)
    assert set(doc_tables("behaviours.md", "values")) == set(VALUES)


@pytest.mark.parametrize("schema", sorted(SCHEMAS))
def test_documented_fields_are_the_types_fields(schema: str) -> None:
    names = [row[0].strip("`") for row in DOCUMENTED[schema]]
    assert sorted(names) == sorted(rust_fields(schema)), schema


@pytest.mark.parametrize("schema", sorted(SCHEMAS))
def test_required_and_defaults(schema: str) -> None:
    """Each field documented "required" is missed when left out of the minimal input; each
    other one's documented default, given explicitly, changes nothing."""
    family, path, minimal = SCHEMAS[schema]
    base = ROBOT if family == "robot" else BEHAVIOUR
    plain = dump(family, put(base, path, minimal))
    for field, _unit, default, _meaning in DOCUMENTED[schema]:
        field = field.strip("`")
        if default == "required":
            assert field in minimal, (schema, field)
            without = {k: v for k, v in minimal.items() if k != field}
            assert f"missing field `{field}`" in parse_error(family, put(base, path, without)), (schema, field)
        else:
            assert field not in minimal, (schema, field)
            value = json.loads(re.match(r"`([^`]*)`", default).group(1))
            assert dump(family, put(base, path, {**minimal, field: value})) == plain, (schema, field, value)
    for field in minimal:
        if field != "kind":
            assert field in [r[0].strip("`") for r in DOCUMENTED[schema]], (schema, field)


@pytest.mark.parametrize("name", sorted(VALUES))
def test_documented_values_are_the_types_variants(name: str) -> None:
    family, path = VALUES[name]
    base = ROBOT if family == "robot" else BEHAVIOUR
    variants = listed(parse_error(family, put(base, path, PROBE)), "variant")
    assert sorted(r[0].strip("`") for r in doc_tables("behaviours.md", "values")[name]) == sorted(variants)


@pytest.mark.parametrize("prefix", sorted({s.split(" kind=")[0] for s in SCHEMAS if " kind=" in s}))
def test_every_kind_is_documented(prefix: str) -> None:
    family, path, minimal = next(v for k, v in SCHEMAS.items() if k.startswith(prefix + " kind="))
    base = ROBOT if family == "robot" else BEHAVIOUR
    variants = listed(parse_error(family, put(base, path, {"kind": PROBE})), "variant")
    kinds = sorted(k.split(" kind=")[1] for k in SCHEMAS if k.startswith(prefix + " kind="))
    assert kinds == sorted(variants), prefix


def test_a_wrong_default_would_fail() -> None:
    """The default check can fail: a value other than the default changes the dump."""
    family, path, minimal = SCHEMAS["robot"]
    assert dump(family, put(ROBOT, path, {**minimal, "gravity_m_s2": 9.0})) != dump(family, put(ROBOT, path, minimal))
