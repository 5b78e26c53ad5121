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
