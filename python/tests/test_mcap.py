"""MCAP leap logs read back with the Python `mcap` package: every topic and schema, the
states and forces equal to what was written, events and metadata, Foxglove's transform tree,
and atomic writes (a failed write leaves neither a file nor a temporary behind, and never
clobbers an existing file)."""

import json
import math

import numpy as np
import pytest

import selfmanip
from selfmanip.leap import Trajectory, write_mcap

mcap_reader = pytest.importorskip("mcap.reader")

TOPICS = {"/tf": "foxglove.FrameTransforms", "/scene": "foxglove.SceneUpdate", "/state": "selfmanip.State",
          "/contact_forces": "selfmanip.ContactForces", "/mode": "selfmanip.Mode", "/events": "selfmanip.Event"}


def synthetic(n=40, seed=1):
    rng = np.random.default_rng(seed)
    t = np.sort(rng.uniform(-0.05, 0.3, n))
    q = rng.normal(size=(n, 5))
    qd = rng.normal(size=(n, 5))
    contacts = ["middle_leg", "rear_leg", "front_body", "rear_body"]
    active = rng.random((n, 4)) < 0.5
    pts = np.where(active[..., None], rng.normal(size=(n, 4, 2)), np.nan)
    frc = np.where(active[..., None], rng.normal(scale=30, size=(n, 4, 2)), np.nan)
    mode = ["".join("1" if a else "0" for a in row) for row in active]
    events = [{"t_s": float(t[5]), "kind": "touchdown", "mode_before": "1010", "mode_after": "0101",
               "contacts": ["middle_leg"], "energy_loss_j": 0.125},
              {"t_s": float(t[30]), "kind": "liftoff", "mode_before": "0101", "mode_after": "0001",
               "contacts": ["rear_leg"], "energy_loss_j": 0.0}]
    return Trajectory(t, q, qd, mode, contacts, pts, frc), events


def read(path):
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f)
        msgs = [(s.name, s.encoding, c.topic, c.message_encoding, m.log_time, json.loads(m.data))
                for s, c, m in reader.iter_messages()]
    with open(path, "rb") as f:
        meta = {m.name: dict(m.metadata) for m in mcap_reader.make_reader(f).iter_metadata()}
    return msgs, meta


def test_synthetic_trajectory_round_trips(tmp_path):
    tr, events = synthetic()
    params = selfmanip.leap.defaults()["params"]
    path = tmp_path / "synthetic.mcap"
    write_mcap(path, params, tr, events, {"note": "synthetic"})
    msgs, meta = read(path)
    assert meta["selfmanip"] == {"note": "synthetic"}
    for schema, enc, topic, menc, _, _ in msgs:
        assert TOPICS[topic] == schema and enc == "jsonschema" and menc == "json"
    by = {t: [m for m in msgs if m[2] == t] for t in TOPICS}
    n = len(tr.t_s)
    assert all(len(by[t]) == n for t in ("/tf", "/scene", "/state", "/contact_forces"))
    # states and forces exactly as written (JSON floats round-trip)
    states = [m[5] for m in by["/state"]]
    assert np.array_equal([s["q"] for s in states], tr.q) and np.array_equal([s["qd"] for s in states], tr.qd)
    assert [s["t_s"] for s in states] == list(tr.t_s) and [s["mode"] for s in states] == tr.mode
    forces = [m[5] for m in by["/contact_forces"]]
    got_f = np.array([[c["force_n"] if c["active"] else [np.nan, np.nan] for c in f["contacts"]] for f in forces])
    got_p = np.array([[c["point_m"] if c["active"] else [np.nan, np.nan] for c in f["contacts"]] for f in forces])
    assert np.array_equal(got_f, tr.contact_forces_n, equal_nan=True)
    assert np.array_equal(got_p, tr.contact_points_m, equal_nan=True)
    # log times: ns since the first sample, in order
    assert [m[4] for m in by["/state"]] == [round((t - tr.t_s[0]) * 1e9) for t in tr.t_s]
    # mode messages exactly at the changes
    changes = [tr.mode[k] for k in range(n) if k == 0 or tr.mode[k] != tr.mode[k - 1]]
    assert [m[5]["mode"] for m in by["/mode"]] == changes
    assert [m[5] for m in by["/events"]] == events
    # Foxglove transform tree: world -> ned -> body -> hips; body pose from q
    tf0 = by["/tf"][0][5]["transforms"]
    assert [(t["parent_frame_id"], t["child_frame_id"]) for t in tf0] == [
        ("world", "ned"), ("ned", "body"), ("body", "middle_hip"), ("body", "rear_hip")]
    body = tf0[1]
    assert (body["translation"]["x"], body["translation"]["z"]) == (tr.q[0, 2], tr.q[0, 3])
    assert 2 * math.atan2(body["rotation"]["y"], body["rotation"]["w"]) == pytest.approx(tr.q[0, 4])
    # one force arrow per active contact
    arrows = [e for e in by["/scene"][0][5]["entities"] if e["id"] == "contact_forces"][0]["arrows"]
    assert len(arrows) == int(np.isfinite(tr.contact_forces_n[0, :, 0]).sum())


def test_failed_writes_are_atomic(tmp_path):
    tr, events = synthetic()
    params = selfmanip.leap.defaults()["params"]
    target = tmp_path / "leap.mcap"
    target.write_bytes(b"old")
    bad = Trajectory(tr.t_s, tr.q[:-1], tr.qd, tr.mode, tr.contacts, tr.contact_points_m, tr.contact_forces_n)
    with pytest.raises(ValueError, match="q"):
        write_mcap(target, params, bad, events)
    with pytest.raises(ValueError, match="kind"):
        write_mcap(target, params, tr, [dict(events[0], kind="explosion")])
    assert target.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["leap.mcap"]
    with pytest.raises(FileNotFoundError, match="no_such_dir"):
        write_mcap(tmp_path / "no_such_dir" / "x.mcap", params, tr, events)
    assert [p.name for p in tmp_path.iterdir()] == ["leap.mcap"]
    write_mcap(target, params, tr, events)
    assert target.read_bytes()[:8] == b"\x89MCAP0\r\n"
    assert [p.name for p in tmp_path.iterdir()] == ["leap.mcap"]


def test_real_leap_log_equals_its_result(tmp_path):
    r = selfmanip.leap("-+", t2=-0.05, gear_ratio=28.0, dt=0.004)
    path = tmp_path / "leap.mcap"
    r.write_mcap(path)
    msgs, meta = read(path)
    states = [m[5] for m in msgs if m[2] == "/state"]
    assert np.array_equal([s["q"] for s in states], r.trajectory.q)
    assert states[0]["q_names"] == r.q_names
    assert [m[5] for m in msgs if m[2] == "/events"] == r.events
    md = meta["selfmanip"]
    assert (md["strategy"], md["word"], md["status"]) == ("-+", r.word, r.status)
    assert json.loads(md["params"]) == r.params
    # the plot reader rebuilds the same trajectory from the log
    from selfmanip.plots import load_leap

    params, tr, info = load_leap(path)
    assert params == r.params and info["word"] == r.word
    assert np.array_equal(tr.q, r.trajectory.q)
    assert np.array_equal(tr.contact_forces_n, r.trajectory.contact_forces_n, equal_nan=True)
