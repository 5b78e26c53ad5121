"""``selfmanip.simulate`` / ``selfmanip.sweep`` for robots that are not RHex (issue 17), from
their description files and behaviour files. Each asserted number comes from an independent
route:

* free fall in closed form: ``t = sqrt(2 h / g)``, ``z(t) = z0 + g t^2 / 2``, ``zdot = g t``,
  and the plastic impact of a level block on two frictionless corners taking all its kinetic
  energy ``m g h`` (derived in ``test_dropped_block_...``);
* the energy balance ``E1 - E0 = W - L`` with ``E`` from ``Robot.energy`` (a second
  formulation of the kinetic and potential energy), ``W`` by quadrature of the sampled joint
  torques times the sampled joint speeds, ``L`` from the events' losses;
* a run repeated alone, or on another thread count (bit-identical columns);
* a Python controller implementing the behaviour file's servo law (the same execution);
* the MCAP file read back with the ``mcap`` package.
"""

from __future__ import annotations

import inspect
import math
import pathlib

import numpy as np
import pytest

import selfmanip
from selfmanip import simulation
from selfmanip.errors import ControllerError, InvalidInputError, InvalidTypeError

DATA = pathlib.Path(__file__).resolve().parents[2] / "crates" / "selfmanip-sim" / "examples" / "data"
HOPPER, HOP = DATA / "hopper.toml", DATA / "hop.toml"
QUAD, PRONK = DATA / "quadruped.toml", DATA / "pronk.toml"
G = 9.81

BLOCK = """
name = "block"
[body]
mass_kg = 2.0
inertia_kg_m2 = 0.05
[[contacts]]
name = "front_corner"
shape = { kind = "point", position_m = [0.2, 0.05] }
friction = { kind = "sliding" }
[[contacts]]
name = "rear_corner"
shape = { kind = "point", position_m = [-0.2, 0.05] }
friction = { kind = "sliding" }
"""


def hopper_q0(drop_m: float, a: float = 0.5) -> list[float]:
    # the foot circle (radius 0.02) under the hip at 2 L cos a, `drop_m` above the ground
    return [a, -2 * a, 0.0, -(drop_m + 0.4 * math.cos(a) + 0.02), 0.0]


def quad_q0(drop_m: float, a: float = 0.5) -> list[float]:
    return [a, -2 * a, a, -2 * a, 0.0, -(drop_m + 0.4 * math.cos(a)), 0.0]


@pytest.fixture(scope="module")
def block_file(tmp_path_factory):
    p = tmp_path_factory.mktemp("block") / "block.toml"
    p.write_text(BLOCK)
    return p


def test_dropped_block_lands_flat_at_the_free_fall_time(block_file):
    """From rest the body falls freely: z(t) = z0 + g t^2/2 (NED, z down), so its corners
    (0.05 m below the body frame) reach the ground after a fall h at t = sqrt(2h/g) with
    zdot = g t. Level, both corners touch at once; a plastic impact on two frictionless
    corners of a level block removes the normal velocity of both, i.e. all of zdot, and, by
    symmetry, creates no spin or sideways motion: T+ = 0, so the loss is
    T- = m (g t)^2 / 2 = m g h. The word is flight then both corners."""
    h, m = 0.3, 2.0
    robot = selfmanip.Robot.from_file(block_file)
    e = selfmanip.simulate(robot, None, [0.0, -(h + 0.05), 0.0], t_final=0.5)
    t_fall = math.sqrt(2 * h / G)
    first = e.events[0]
    assert first["kind"] == "touchdown"
    assert first["t_s"] == pytest.approx(t_fall, abs=1e-9)
    assert sorted(first["contacts"]) == ["front_corner", "rear_corner"]
    assert first["energy_loss_j"] == pytest.approx(m * G * h, rel=1e-9)
    assert len(e.events) == 1 and e.status == "final_time"
    assert e.word == ["00", "11"]
    assert e.landing["before"]["zdot_m_s"] == pytest.approx(G * t_fall, rel=1e-8)
    # the sampled flight follows the closed form
    tr = e.trajectory(0.01)
    before = tr.t_s < t_fall
    iz = tr.q_names.index("z")
    z_closed = -(h + 0.05) + 0.5 * G * tr.t_s[before] ** 2
    np.testing.assert_allclose(tr.q[before, iz], z_closed, atol=1e-9)
    # at rest on the ground afterwards, the corners carrying the weight: -lam_n sums to m g
    after = tr.t_s > t_fall + 0.02
    np.testing.assert_allclose(tr.q[after, iz], -0.05, atol=1e-9)
    np.testing.assert_allclose(-np.nansum(tr.contact_forces_n[after, :, 1], axis=1), m * G, rtol=1e-9)
    # a description path and a Robot give the same execution
    same = selfmanip.simulate(block_file, None, [0.0, -(h + 0.05), 0.0], t_final=0.5)
    assert same.events == e.events


def test_block_sliding_on_coulomb_corners_stops_at_v0_over_mu_g():
    """Coulomb friction at body sites (not legs): a level block sliding on both corners with
    mu_k = mu decelerates at mu g (the corners' normal forces sum to m g, each friction force
    mu |N| against the sliding), so it sticks at t = v0 / (mu g) after x = v0^2 / (2 mu g), and
    the friction takes all its kinetic energy: W_fr = -m v0^2 / 2 with the energy balance
    closed (E1 - E0 = W + W_fr - L)."""
    m, mu, v0 = 2.0, 0.3, 0.9
    robot = selfmanip.Robot.from_toml(BLOCK.replace('{ kind = "sliding" }',
                                                    f'{{ kind = "sticking", mu = {mu}, mu_kinetic = {mu} }}'))
    e = selfmanip.simulate(robot, None, [0.0, -0.05, 0.0], [v0, 0.0, 0.0], t_final=0.5,
                           contacts="front_corner:slide,rear_corner:slide")
    t_stop = v0 / (mu * G)
    stick = [ev for ev in e.events if ev["kind"] == "stick"]
    assert stick and stick[0]["t_s"] == pytest.approx(t_stop, abs=1e-8)
    assert e.status == "final_time"
    tr = e.trajectory(0.01)
    ix = tr.q_names.index("x")
    assert tr.q[-1, ix] == pytest.approx(v0**2 / (2 * mu * G), abs=1e-8)
    er = e.energy_report()
    assert er.friction_work_j == pytest.approx(-0.5 * m * v0**2, rel=1e-7)
    assert abs(er.residual_j) < 1e-7


def _joint_work(e: simulation.Execution, robot: selfmanip.Robot, dt: float, free_in_flight: bool) -> float:
    """W = sum over segments of the trapezoid of tau . thetadot on samples inside each segment
    (a torque on a massless joint out of contact does no work: left out when
    `free_in_flight`)."""
    tr = e.trajectory(dt)
    nj = robot.n_joints
    power = np.sum(tr.tau * tr.qd[:, :nj], axis=1)
    w = 0.0
    for s in e.segments:
        if free_in_flight and set(s["mode"]) <= {"0"}:
            continue
        # the segment's own dense samples plus its ends
        ts = np.concatenate([[s["t0_s"]], tr.t_s[(tr.t_s > s["t0_s"]) & (tr.t_s < s["t1_s"])], [s["t1_s"]]])
        if len(ts) < 3:
            continue
        inside = (tr.t_s > s["t0_s"]) & (tr.t_s < s["t1_s"])
        p = power[inside]
        w += np.trapezoid(p, tr.t_s[inside]) if hasattr(np, "trapezoid") else np.trapz(p, tr.t_s[inside])
        # the partial intervals at both ends, by the nearest sample's power
        w += p[0] * (tr.t_s[inside][0] - s["t0_s"]) + p[-1] * (s["t1_s"] - tr.t_s[inside][-1])
    return float(w)


@pytest.mark.parametrize("name", ["hopper", "quadruped"])
def test_energy_balances_over_a_landing_and_a_hop(name):
    """E1 - E0 = W - L over a drop, a landing and a hop: E from Robot.energy at the start
    and end states, W by quadrature of sampled torques and joint speeds, L from the events.
    The massless-legged hopper lands without loss (a massless foot stops without an impulse
    on the body); the massive-legged quadruped loses energy in plastic touchdowns."""
    if name == "hopper":
        robot, behaviour, q0, t_final, free = selfmanip.Robot.from_file(HOPPER), HOP, hopper_q0(0.1), 0.45, True
        e = selfmanip.simulate(robot, behaviour, q0, t_final=t_final)
    else:
        robot, behaviour, q0, t_final, free = selfmanip.Robot.from_file(QUAD), PRONK, quad_q0(0.05), 0.3, False
        e = selfmanip.simulate(robot, behaviour, q0, t_final=t_final, labels=["fore_foot", "hind_foot"])
    flights = [c for c in e.word if set(c) <= {"0"}]
    assert len(flights) >= 2, e.word  # a landing and a hop
    e0 = sum(robot.energy(q0, [0.0] * robot.nq))
    e1 = sum(robot.energy(e.q_end, e.qd_end))
    loss = sum(ev["energy_loss_j"] for ev in e.events)
    w = _joint_work(e, robot, 5e-5, free)
    r = e.energy_report()
    scale = abs(e0) + abs(w) + loss
    assert abs(w) > 0.1, "the legs work"
    assert (loss > 1e-3) == (name == "quadruped"), loss
    # the conservation law by the independent route (the quadrature's error, from the
    # torque's jumps at phase changes, is ~2e-3 J at this dt; it halves with dt)
    assert e1 - e0 == pytest.approx(w - loss, abs=2e-4 * scale)
    # and the engine's own bookkeeping agrees with each term
    assert r.initial_j == pytest.approx(e0, rel=1e-12)
    assert r.final_j == pytest.approx(e1, rel=1e-12)
    assert r.joint_work_j == pytest.approx(w, abs=2e-4 * scale)
    assert r.impact_loss_j == pytest.approx(loss, abs=1e-12)
    assert abs(r.residual_j) < 1e-6 * scale


def _sweep(threads: int, over=None):
    return selfmanip.sweep(HOPPER, HOP, over=over or {"kp_push": [35.0, 45.0, 55.0], "t_compress": [0.04, 0.06]},
                           q0=hopper_q0(0.1), t_final=0.4, threads=threads)


def test_sweeps_are_bit_identical_across_thread_counts_and_equal_runs_alone():
    one, two = _sweep(1), _sweep(2)
    assert list(one) == list(two)
    for k in one:
        a, b = np.asarray(one[k]), np.asarray(two[k])
        assert a.dtype == b.dtype and a.tobytes() == b.tobytes(), k
    # the grid: the last name varying fastest
    assert one["kp_push"].tolist() == [35.0, 35.0, 45.0, 45.0, 55.0, 55.0]
    assert one["t_compress"].tolist() == [0.04, 0.06] * 3
    # each point is the run alone with its values set by name
    for i in (0, 3, 5):
        e = selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), t_final=0.4,
                               params={"kp_push": one["kp_push"][i], "t_compress": one["t_compress"][i]})
        assert one["status"][i] == e.status
        assert one["word"][i] == e.word_string
        assert one["apex_z_m"][i] == -e.apex["z_m"]  # sweeps report z up, the run NED
        assert one["end_x"][i] == e.q_end[2]
        assert one["n_events"][i] == len(e.events)
    # the apex differs between points: the parameters reached the runs
    assert len(set(one["apex_z_m"].tolist())) == 6


def test_a_failing_point_keeps_the_good_ones():
    bad = _sweep(2, {"kp_spring": [60.0, -5.0, 60.0]})
    assert bad["status"].tolist() == ["final_time", "invalid_value", "final_time"]
    assert "kp_n_m_per_rad" in bad["error"][1] and bad["error"][0] == ""
    assert math.isnan(bad["apex_z_m"][1])
    good = _sweep(1, {"kp_spring": [60.0]})
    for k in ("apex_z_m", "t_end_s", "end_z", "word"):
        assert bad[k][0] == good[k][0] == bad[k][2], k
    # a value of the wrong kind fails its point only; a name that names nothing fails the call
    mixed = _sweep(1, {"t_compress": [0.05, "soon"]})
    assert mixed["status"].tolist() == ["final_time", "unknown_reference"]
    with pytest.raises(InvalidInputError) as ei:
        _sweep(1, {"legs.middle.links[0].length_m": [0.1]})
    assert ei.value.field == "legs.middle.links[0].length_m"
    with pytest.warns(selfmanip.AllPointsFailedWarning):
        _sweep(1, {"kp_spring": [-1.0]})


def test_the_rhex_preset_still_dispatches():
    r = selfmanip.sweep("++", t2=[0.0], gear_ratio=28.0, threads=1)
    assert r["strategy"].tolist() == ["++"] and "apex_z_m" in r
    assert selfmanip.sweep is simulation.sweep


def test_mcap_reads_back_with_the_mcap_package(tmp_path):
    from mcap.reader import make_reader
    import json

    e = selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), t_final=0.4)
    path = e.to_mcap(tmp_path / "hop.mcap", dt=0.01, metadata={"case": "test"})
    tr = e.trajectory(0.01)
    by_topic: dict[str, list] = {}
    with open(path, "rb") as f:
        reader = make_reader(f)
        for schema, channel, message in reader.iter_messages():
            by_topic.setdefault(channel.topic, []).append(json.loads(message.data))
        meta = {m.name: dict(m.metadata) for m in reader.iter_metadata()}
    assert {"/tf", "/scene", "/state", "/contact_forces", "/mode", "/events"} <= set(by_topic)
    states = by_topic["/state"]
    assert len(states) == len(tr.t_s)
    np.testing.assert_array_equal([s["t_s"] for s in states], tr.t_s)
    np.testing.assert_array_equal(np.array([s["q"] for s in states]), tr.q)
    assert [(m["t_s"], m["kind"]) for m in by_topic["/events"]] == [(x["t_s"], x["kind"]) for x in e.events]
    md = meta["selfmanip"]
    assert md["word"] == e.word_string and md["status"] == e.status and md["case"] == "test"
    assert md["robot"] == "hopper"
    # a frame per link: the hopper's two links under the body
    frames = {t["child_frame_id"] for msg in by_topic["/tf"][:1] for t in msg["transforms"]}
    assert {"body", "leg_link0", "leg_link1"} <= frames


def test_plot_writes_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    e = selfmanip.simulate(QUAD, PRONK, quad_q0(0.05), t_final=0.3, labels=["fore_foot", "hind_foot"])
    out = tmp_path / "pronk.png"
    e.plot(out)
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    from selfmanip.cli_leap import write_table
    from selfmanip.plots import plot_file

    table = selfmanip.sweep(QUAD, PRONK, over={"kp_push": [60.0, 80.0]}, q0=quad_q0(0.05), t_final=0.3, threads=2)
    write_table(table, str(tmp_path / "s.csv"))
    plot_file(tmp_path / "s.csv", tmp_path / "s.png")
    assert (tmp_path / "s.png").read_bytes()[:4] == b"\x89PNG"


TARGETS = {"fore[0]": (0.5, 30.0, 0.3), "fore[1]": (-1.2, 40.0, 0.5), "hind[0]": (0.45, 30.0, 0.3),
           "hind[1]": (-1.1, 40.0, 0.5)}
SERVO = {"joints": [{"joint": j, "phases": [{"name": "hold", "torque": {
    "kind": "servo", "target_rad": target, "kp_n_m_per_rad": kp, "kd_n_m_s_per_rad": kd}}]}
    for j, (target, kp, kd) in TARGETS.items()]}


def test_a_python_controller_reproduces_the_behaviour_it_implements():
    """The servo law tau = kp (target - q) + kd (0 - qd) as a Python callable gives the
    execution of the behaviour dict that states it: the quadruped with its massive legs (every
    joint in the dynamics) dropped onto its servoed legs."""
    q0 = quad_q0(0.05)
    gains = list(TARGETS.values())

    def law(t, q, qd, mode):
        return [kp * (target - q[j]) - kd * qd[j] for j, (target, kp, kd) in enumerate(gains)]

    labels = ["fore_foot", "hind_foot"]
    data = selfmanip.simulate(QUAD, SERVO, q0, t_final=0.3, labels=labels)
    calls = []

    def counted(t, q, qd, mode):
        calls.append(mode)
        return law(t, q, qd, mode)

    py = selfmanip.simulate(QUAD, None, q0, t_final=0.3, controller=counted, labels=labels)
    assert len(data.events) >= 1
    assert py.word == data.word and py.status == data.status
    assert [x["kind"] for x in py.events] == [x["kind"] for x in data.events]
    for a, b in zip(py.events, data.events):
        assert a["t_s"] == pytest.approx(b["t_s"], abs=1e-9)
    np.testing.assert_allclose(py.q_end, data.q_end, atol=1e-8)
    assert {"00", "11"} <= set(calls)  # the mode label in the robot's contact order
    tr = py.trajectory(0.01)
    np.testing.assert_allclose(tr.tau, [law(0, q, qd, "") for q, qd in zip(tr.q, tr.qd)], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(data.trajectory(0.01).tau, tr.tau, atol=1e-6)


def test_python_controller_errors_are_typed():
    q0 = hopper_q0(0.05)
    with pytest.raises(ControllerError) as ei:
        selfmanip.simulate(HOPPER, None, q0, t_final=0.3, controller=lambda t, q, qd, m: [0.0, 1.0 / (t - t)])
    assert isinstance(ei.value.__cause__, ZeroDivisionError) and ei.value.field == "controller"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, None, q0, t_final=0.3, controller=lambda t, q, qd, m: [0.0])
    assert ei.value.field == "controller" and "2 joints" in str(ei.value)
    with pytest.raises(InvalidInputError):
        selfmanip.simulate(HOPPER, None, q0, t_final=0.3, controller=lambda t, q, qd, m: [0.0, math.nan])
    with pytest.raises(InvalidTypeError):
        selfmanip.simulate(HOPPER, None, q0, t_final=0.3, controller=lambda t, q, qd, m: "torques")
    with pytest.raises(InvalidTypeError):
        selfmanip.simulate(HOPPER, None, q0, controller=42)
    with pytest.raises(InvalidInputError):
        selfmanip.simulate(HOPPER, HOP, q0, controller=lambda t, q, qd, m: [0.0, 0.0])


KNEE = '[[joints]]\njoint = "leg[1]"\n[[joints.phases]]\nname = "a"\n'
BAD_BEHAVIOURS = {
    "unknown joint": ('[[joints]]\njoint = "arm[0]"\n[[joints.phases]]\nname = "a"\n', "joints[0].joint"),
    "unknown event": (KNEE + '[[joints.phases]]\nname = "b"\nstart = { event = "takeoff" }\n',
                      "joints[0].phases[1].start.event"),
    "unknown event kind": (KNEE + '[[joints.phases]]\nname = "b"\nstart = { on = "landing" }\n', "behaviour"),
    "cyclic phases": ('[[joints]]\njoint = "leg[0]"\n[[joints.phases]]\nname = "a"\n[[joints.phases]]\nname = "b"\n'
                      'start = { on = "phase", phase = "leg[1].d" }\n[[joints]]\njoint = "leg[1]"\n'
                      '[[joints.phases]]\nname = "c"\n[[joints.phases]]\nname = "d"\n'
                      'start = { on = "phase", phase = "leg[0].b", delay_s = 0.1 }\n', "joints[0].phases[1].start"),
    "negative gain": (KNEE + 'torque = { kind = "servo", kp_n_m_per_rad = -3.0, kd_n_m_s_per_rad = 1.0 }\n',
                      "joints[0].phases[0].torque.kp_n_m_per_rad"),
    "NaN": (KNEE + 'torque = { kind = "servo", kp_n_m_per_rad = 3.0, kd_n_m_s_per_rad = nan }\n',
            "joints[0].phases[0].torque.kd_n_m_s_per_rad"),
}


@pytest.mark.parametrize("case", sorted(BAD_BEHAVIOURS))
def test_bad_behaviour_files_are_typed_errors_naming_the_field(case, tmp_path):
    text, field = BAD_BEHAVIOURS[case]
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, p, hopper_q0(0.1), t_final=0.1)
    assert isinstance(ei.value, ValueError)
    assert ei.value.field == field, str(ei.value)
    assert (field in str(ei.value)) or case == "unknown event kind"
    if case == "cyclic phases":
        assert "leg[0].b -> leg[1].d -> leg[0].b" in str(ei.value)
    if case == "unknown event kind":
        assert "landing" in str(ei.value)


def test_bad_inputs_name_their_field():
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, HOP, [0.0, 0.0, 0.0])
    assert ei.value.field == "initial.q"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), rtoll=1e-6)
    assert ei.value.field == "options.rtoll"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), t_final=-1.0)
    assert ei.value.field == "options.t_final_s"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), params={"kp_push": math.nan})
    assert ei.value.field == "kp_push"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), terrain={"kind": "ledge", "height_m": -1.0, "distance_m": 0.3})
    assert ei.value.field.startswith("terrain")
    with pytest.raises(InvalidTypeError):
        selfmanip.simulate(42, HOP, hopper_q0(0.1))
    with pytest.raises(FileNotFoundError):
        selfmanip.simulate(HOPPER, DATA / "no-such.toml", hopper_q0(0.1))


def test_stop_at_apex_and_terrain():
    e = selfmanip.simulate(HOPPER, HOP, hopper_q0(0.1), t_final=1.0, stop_at="apex")
    assert e.status == "apex" and e.apex is not None
    # the engine stopped where the body's vertical speed vanishes
    assert abs(e.qd_end[3]) < 1e-6
    ledge = selfmanip.simulate(HOPPER, DATA / "hop_up.toml", hopper_q0(0.03), [0.0, 0.0, 0.6, 0.0, 0.0],
                               terrain={"kind": "ledge", "height_m": 0.04, "distance_m": 0.55}, t_final=0.6)
    flat = selfmanip.simulate(HOPPER, DATA / "hop_up.toml", hopper_q0(0.03), [0.0, 0.0, 0.6, 0.0, 0.0],
                              terrain="flat", t_final=0.6)
    assert ledge.status in simulation.COMPLETE_STATUSES and flat.status in simulation.COMPLETE_STATUSES


@pytest.mark.parametrize("example", ["hopper", "ledge", "quadruped"])
def test_examples_run_small(example, tmp_path, monkeypatch):
    pytest.importorskip("matplotlib")
    import importlib.util

    root = pathlib.Path(__file__).resolve().parents[2] / "python" / "examples"
    monkeypatch.syspath_prepend(str(root))  # as `python python/examples/X.py` does: they share hopper.py
    spec = importlib.util.spec_from_file_location(example, root / f"{example}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    assert mod.main(["--out-dir", str(tmp_path), "--t-final", "0.3"]) == 0
    outs = {"hopper": ["hopper"], "ledge": ["ledge"], "quadruped": ["pronk", "bound"]}[example]
    for name in outs:
        assert (tmp_path / f"{name}.mcap").read_bytes()[:8] == b"\x89MCAP0\r\n"
        assert (tmp_path / f"{name}.png").read_bytes()[:4] == b"\x89PNG"


def test_public_functions_are_annotated():
    from selfmanip import cli_sim

    missing = []
    for mod in (simulation, cli_sim):
        for name, obj in vars(mod).items():
            if name.startswith("_") or getattr(obj, "__module__", None) != mod.__name__:
                continue
            fns = [(name, obj)] if inspect.isfunction(obj) else (
                [(f"{name}.{k}", v) for k, v in vars(obj).items() if inspect.isfunction(v) and not k.startswith("_")]
                if inspect.isclass(obj) else [])
            for qual, fn in fns:
                sig = inspect.signature(fn)
                for p in sig.parameters.values():
                    if p.name not in ("self", "cls") and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD) \
                            and p.annotation is inspect.Parameter.empty:
                        missing.append(f"{qual}({p.name})")
                if sig.return_annotation is inspect.Signature.empty:
                    missing.append(f"{qual} -> ?")
    assert not missing, missing
