"""Issue 30 item 1: a two-foot landing lands in one reset on the defaults — the newcomer's
bounder of the issue's appendix (a 2 kg body, two two-link legs, point feet, mu = 0.8)."""

import json
import math

import pytest

import selfmanip

G = 9.81
LINK = {"length_m": 0.15, "mass_kg": 0.1, "inertia_kg_m2": 1.875e-4}
Q0 = [0.5, -1.0, 0.5, -1.0, 0.0, -0.33, 0.0]


def foot(leg):
    return {"name": f"{leg}_foot", "leg": leg, "shape": {"kind": "point", "position_m": [0, 0.15]},
            "friction": {"kind": "sticking", "mu": 0.8}}


def description(shin_mass_kg=0.1):
    shin = dict(LINK, mass_kg=shin_mass_kg, inertia_kg_m2=1.875e-4 if shin_mass_kg else 0.0)
    return {"name": "bounder", "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.0267},
            "contacts": [foot("front"), foot("hind")],
            "legs": [{"name": n, "hip_m": [x, 0.0], "links": [dict(LINK), dict(shin)]}
                     for n, x in (("front", 0.2), ("hind", -0.2))]}


def servo(target=None, kp=30.0, kd=0.5, limit=6.0):
    s = {"kind": "servo", "kp_n_m_per_rad": kp, "kd_n_m_s_per_rad": kd}
    if target is not None:
        s["target_rad"] = target
    if limit is not None:
        s["torque_limit_n_m"] = limit
    return s


LIMP = {"joints": [{"joint": j, "phases": [{"name": "h", "torque": servo(kp=20.0, kd=0.3, limit=None)}]}
                   for j in ("front[0]", "front[1]", "hind[0]", "hind[1]")]}


def bound(kp):
    """Hips servo to 0.5 rad; knees push from -1.0 to -0.2 rad at 0.2 s, back to -1.0 in flight."""
    hips = [{"joint": f"{leg}[0]", "phases": [{"name": "hold", "torque": servo(0.5, kp)}]}
            for leg in ("front", "hind")]
    knees = [{"joint": f"{leg}[1]", "phases": [
        {"name": "crouch", "torque": servo(-1.0, kp)},
        {"name": "push", "start": {"at_s": 0.2}, "torque": servo(-0.2, kp)},
        {"name": "swing", "start": {"on": "flight"}, "torque": servo(-1.0, kp)}]}
        for leg in ("front", "hind")]
    return {"joints": hips + knees}


@pytest.fixture(scope="module")
def bounder(tmp_path_factory):
    path = tmp_path_factory.mktemp("bounder") / "bounder.json"
    path.write_text(json.dumps(description()))
    return selfmanip.Robot.from_file(path)


def no_energy_gain(e):
    return all(ev["energy_loss_j"] >= -1e-12 for ev in e.events if math.isfinite(ev["energy_loss_j"]))


def test_level_drop_lands_in_one_event_at_the_free_fall_time(bounder):
    gaps = bounder.contact_gaps(Q0)
    h = gaps["front_foot"]
    assert gaps["hind_foot"] == pytest.approx(h, abs=1e-12)
    e = selfmanip.simulate(bounder, LIMP, Q0, t_final=0.4)
    assert e.status != "zeno"
    first = e.events[0]
    assert first["kind"] == "touchdown"
    assert sorted(first["contacts"]) == ["front_foot", "hind_foot"]
    assert first["t_s"] == pytest.approx(math.sqrt(2 * h / G), abs=1e-9)
    # nothing lets go at the landing's round-off: the next event is the legs' own motion
    assert len(e.events) == 1 or e.events[1]["t_s"] - first["t_s"] > 1e-3
    assert no_energy_gain(e)


def test_the_bound_sweep_ends_without_zeno(bounder):
    statuses = []
    for i in range(20):
        kp = 10.0 + 2.0 * i
        e = selfmanip.simulate(bounder, bound(kp), Q0, t_final=0.6)
        assert no_energy_gain(e), kp
        statuses.append((kp, e.status))
    assert [s for s in statuses if s[1] == "zeno"] == []


SWING = {"kind": "swing", "target_rad": -1.0, "speed_rad_s": 15.0, "accel_rad_s2": 600.0}


def jump(kp=30.0):
    """Hips servo to 0.5 rad; knees push from -1.0 to -0.2 rad at 0.2 s and swing back to -1.0
    in flight with the examples' swing settings (15 rad/s, 600 rad/s^2)."""
    hips = [{"joint": f"{leg}[0]", "phases": [{"name": "hold", "torque": servo(0.5, kp)}]}
            for leg in ("front", "hind")]
    knees = [{"joint": f"{leg}[1]", "phases": [
        {"name": "crouch", "torque": servo(-1.0, kp)},
        {"name": "push", "start": {"at_s": 0.2}, "torque": servo(-0.2, kp)},
        {"name": "swing", "start": {"on": "flight"}, "torque": servo(-1.0, kp), "motion": SWING}]}
        for leg in ("front", "hind")]
    return {"joints": hips + knees}


@pytest.fixture(scope="module")
def massless_shins(tmp_path_factory):
    path = tmp_path_factory.mktemp("bounder") / "bounder_massless.json"
    path.write_text(json.dumps(description(shin_mass_kg=0.0)))
    return selfmanip.Robot.from_file(path)


def test_massless_shin_jump_flies_and_balances_energy(massless_shins):
    """Issue 30 item 2: the shins leave the ground on their servo's torque-free manifold
    (docs/singular-transitions.md section 10) -- no touchdown that changes no mode, a flight,
    and the energy balance E1 - E0 = W + W_d + W_fr - L closed to 1e-6 J."""
    e = selfmanip.simulate(massless_shins, jump(), Q0, t_final=0.6)
    assert e.status == "final_time", e.reason
    kinds = [(ev["kind"], ev["mode_before"], ev["mode_after"]) for ev in e.events]
    assert not [k for k in kinds if k[0] == "touchdown" and k[1] == k[2]], kinds
    assert not [k for k in kinds if k[0] == "zeno_truncation"], kinds
    # a flight after the push: both feet off the ground for longer than a millisecond
    flights = [(a["t_s"], b["t_s"]) for a, b in zip(e.events, e.events[1:])
               if a["t_s"] > 0.2 and a["mode_after"] == "00"]
    assert flights and max(b - a for a, b in flights) > 1e-3, kinds
    er = e.energy_report()
    assert abs(er.residual_j) < 1e-6, er
    assert no_energy_gain(e)
