"""``selfmanip.periodic_orbit`` and ``simulate(..., sensitivity=True)`` (issue 18) on the
one-legged hopper of ``crates/selfmanip-sim/examples/data`` hopping under
``hop_periodic.toml``. Every asserted number has an independent route:

* the section Jacobian against central finite differences of whole apex-to-apex runs of the
  public ``simulate(..., stop_at="apex")``, and the non-trivial multipliers against those of
  the finite-difference matrix;
* the fixed point against one ``simulate`` run of three periods (every recorded apex is the
  fixed point again, a stride further on);
* conservation: the leg force passes through the body's centre of mass, so ``phidot`` is
  conserved and its row of the monodromy is a unit row (closed form);
* the trivial multipliers: ``monodromy @ f = 0`` and ``period_monodromy @ f = f`` with the
  flow ``f`` from the trajectory's finite differences at the apex;
* the state Jacobian of ``simulate(..., sensitivity=True)`` against central differences of
  whole ``simulate`` runs, and a flagged event (``None`` with its reason);
* the example script run end to end.
"""

from __future__ import annotations

import pathlib
import runpy
import sys

import numpy as np
import pytest

import selfmanip
from selfmanip.errors import EngineError, InvalidInputError, InvalidTypeError

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = ROOT / "crates" / "selfmanip-sim" / "examples" / "data"
HOPPER, HOP = DATA / "hopper.toml", DATA / "hop_periodic.toml"
GUESS = [0.5, -1.0, 0.0, -0.45, 0.0]
# every component to the same absolute tolerance: differences of whole runs resolve a
# derivative no better than each run's error
TIGHT = dict(rtol=1e-11, atol=1e-13, event_tol_s=1e-13, velocity_tolerance="uniform")


@pytest.fixture(scope="module")
def orbit() -> selfmanip.PeriodicOrbit:
    return selfmanip.periodic_orbit(HOPPER, HOP, GUESS)


def _apex_state(q0: np.ndarray, qd0: np.ndarray) -> tuple[np.ndarray, list[str]]:
    e = selfmanip.simulate(HOPPER, HOP, list(q0), list(qd0), t_final=2.0, stop_at="apex", **TIGHT)
    assert e.status == "apex"
    return np.concatenate([e.q_end, e.qd_end]), [ev["kind"] for ev in e.events]


def test_orbit_section_jacobian_matches_finite_differences(orbit: selfmanip.PeriodicOrbit) -> None:
    assert orbit.residual <= 1e-9
    assert [e["kind"] for e in orbit.events] == ["touchdown", "liftoff", "apex"]
    assert orbit.cyclic == ["x"]
    names = orbit.state_names
    idx = [names.index(n) for n in orbit.section_coordinates]
    assert "zdot" not in orbit.section_coordinates and "x" not in orbit.section_coordinates
    nq = len(orbit.q)
    h = 1e-6
    fd = np.zeros((len(idx), len(idx)))
    for k, c in enumerate(idx):
        xp, xm = orbit.x.copy(), orbit.x.copy()
        xp[c] += h
        xm[c] -= h
        (yp, sp), (ym, sm) = _apex_state(xp[:nq], xp[nq:]), _apex_state(xm[:nq], xm[nq:])
        assert sp == sm == ["touchdown", "liftoff", "apex"]
        fd[:, k] = (yp[idx] - ym[idx]) / (2 * h)
    err = np.abs(orbit.section_jacobian - fd).max() / max(1.0, np.abs(fd).max())
    assert err < 1e-5, err
    # the multipliers away from the (defective, ill-conditioned) unit pair
    fd_mult = np.linalg.eigvals(fd)
    for lam in orbit.section_multipliers:
        if abs(lam - 1) > 1e-3:
            assert np.min(np.abs(fd_mult - lam)) < 1e-5, (lam, fd_mult)
    assert abs(orbit.section_multipliers[0]) > 1.1
    assert orbit.stability == "unstable" and not orbit.stable


def test_orbit_returns_to_itself_over_three_periods(orbit: selfmanip.PeriodicOrbit) -> None:
    e = selfmanip.simulate(HOPPER, HOP, list(orbit.q), list(orbit.qd), t_final=3 * orbit.period_s + 0.05,
                           **TIGHT)
    apexes = [ev["t_s"] for ev in e.events if ev["kind"] == "apex"]
    assert len(apexes) == 3
    assert np.allclose(apexes, orbit.period_s * np.arange(1, 4), atol=1e-8)
    tr = e.trajectory(0.01)
    # states at the recorded apexes, from the dense output: x* with x advanced by the stride
    for k, t in enumerate(apexes):
        j = int(np.argmin(np.abs(tr.t_s - t)))
        if abs(tr.t_s[j] - t) > 1e-12:
            continue
        x = np.concatenate([tr.q[j], tr.qd[j]])
        want = orbit.x.copy()
        want[orbit.state_names.index("x")] += (k + 1) * orbit.drift[0]
        assert np.abs(x - want).max() < 1e-7
    # the end state of a run stopped at the first apex is the fixed point
    x1, _ = _apex_state(orbit.q, orbit.qd)
    want = orbit.x.copy()
    want[orbit.state_names.index("x")] += orbit.drift[0]
    assert np.abs(x1 - want).max() < 1e-8


def test_conserved_pitch_rate_and_trivial_multipliers(orbit: selfmanip.PeriodicOrbit) -> None:
    names = orbit.state_names
    n = len(names)
    i = names.index("phidot")
    assert np.abs(orbit.monodromy[i] - np.eye(n)[i]).max() < 1e-9
    assert orbit.rank_deficiency == 1
    # f(x*) from central differences of the sampled trajectory around the apex at t = T
    e = selfmanip.simulate(HOPPER, HOP, list(orbit.q), list(orbit.qd), t_final=0.004, **TIGHT)
    tr = e.trajectory(0.001)
    y = np.concatenate([tr.q, tr.qd], axis=1)
    f = (y[2] - y[0]) / (tr.t_s[2] - tr.t_s[0])   # at t = 0.001 s, within O(dt^2) of x*'s flow
    f0 = (y[1] - y[0]) / (tr.t_s[1] - tr.t_s[0])
    assert np.abs(f - f0).max() < 0.05 * np.abs(f).max()
    dpf = np.abs(orbit.monodromy @ f).max() / np.abs(f).max()
    mtf = np.abs(orbit.period_monodromy @ f - f).max() / np.abs(f).max()
    assert dpf < 0.05 and mtf < 0.05, (dpf, mtf)
    # exactly one multiplier of DP is ~0 more than those of the section map
    assert len(orbit.multipliers) == n and len(orbit.section_multipliers) == n - 2


def test_orbit_is_deterministic(orbit: selfmanip.PeriodicOrbit) -> None:
    again = selfmanip.periodic_orbit(HOPPER, HOP, GUESS)
    assert np.array_equal(again.x, orbit.x)
    assert np.array_equal(again.monodromy, orbit.monodromy)
    assert again.period_s == orbit.period_s


def test_simulate_sensitivity_matches_finite_differences(orbit: selfmanip.PeriodicOrbit) -> None:
    q0, qd0 = list(orbit.q), list(orbit.qd)
    # through the touchdown and the liftoff, ending once the leg's free-joint transient after
    # the liftoff has died out (within ~50 ms of it the leg-velocity rows differ from finite
    # differences by up to 4e-4 relative: see docs/periodic-orbits.md, "Known limits")
    tf = 0.4
    e = selfmanip.simulate(HOPPER, HOP, q0, qd0, t_final=tf, sensitivity=True, **TIGHT)
    assert [ev["kind"] for ev in e.events] == ["touchdown", "liftoff"]
    n = 2 * len(q0)
    for ev in e.events:
        assert ev["saltation_status"] == "defined" and ev["saltation_reason"] is None
        assert ev["saltation"].shape == (n, n) and ev["time_gradient"].shape == (n,)
    jac = e.state_jacobian
    assert jac.shape == (n, n)
    x0 = np.concatenate([orbit.q, orbit.qd])
    h = 1e-6
    zd = orbit.state_names.index("zdot")
    for c in range(n):
        if c == zd:
            continue   # a rise off the apex adds an apex event right away; the FD is one-sided
        xp, xm = x0.copy(), x0.copy()
        xp[c] += h
        xm[c] -= h
        ep = selfmanip.simulate(HOPPER, HOP, list(xp[:n // 2]), list(xp[n // 2:]), t_final=tf, **TIGHT)
        em = selfmanip.simulate(HOPPER, HOP, list(xm[:n // 2]), list(xm[n // 2:]), t_final=tf, **TIGHT)
        col = (np.concatenate([ep.q_end, ep.qd_end]) - np.concatenate([em.q_end, em.qd_end])) / (2 * h)
        assert np.abs(jac[:, c] - col).max() < 1e-5 * max(1.0, np.abs(col).max()), c


def test_flagged_event_has_no_saltation_and_a_reason(orbit: selfmanip.PeriodicOrbit) -> None:
    # a run cut by its event budget ends on an event with no flow after it
    e = selfmanip.simulate(HOPPER, HOP, list(orbit.q), list(orbit.qd), t_final=0.4, sensitivity=True,
                           max_events=1)
    assert e.status == "event_budget"
    (ev,) = e.events
    assert ev["saltation"] is None and ev["saltation_status"] == "unsupported"
    assert "no flow after" in ev["saltation_reason"]
    assert e.state_jacobian is None
    # an apex recorded on the way is no reset: its saltation the identity, the state
    # Jacobian carried through it (against central differences: test_simulate_sensitivity_paths.py)
    e = selfmanip.simulate(HOPPER, HOP, list(orbit.q), list(orbit.qd), t_final=orbit.period_s + 0.1,
                           sensitivity=True)
    assert [ev["kind"] for ev in e.events] == ["touchdown", "liftoff", "apex"]
    apex = e.events[-1]
    assert apex["saltation_status"] == "defined" and apex["saltation_reason"] is None
    assert np.abs(apex["saltation"] - np.eye(10)).max() < 1e-12
    assert e.state_jacobian is not None
    # without sensitivity=True nothing is attached
    plain = selfmanip.simulate(HOPPER, HOP, list(orbit.q), list(orbit.qd), t_final=0.3)
    assert plain.state_jacobian is None and "saltation" not in plain.events[0]


def test_bad_input_names_the_field() -> None:
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, section="touchdown")
    assert ei.value.field == "section"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, tolerance=1e-9)
    assert ei.value.field == "tolerance"
    with pytest.raises(InvalidTypeError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, tol="small")
    assert ei.value.field == "tol"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, cyclic=["y"])
    assert ei.value.field == "cyclic[0]"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, max_period_s=-1.0)
    assert ei.value.field == "max_period_s"
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, rtol=0.0)
    assert ei.value.field == "rtol"
    with pytest.raises(InvalidTypeError) as ei:
        selfmanip.simulate(HOPPER, HOP, GUESS, sensitivity="yes")
    assert ei.value.field == "sensitivity"
    # the iteration budget: a typed engine error, not a hang
    with pytest.raises(EngineError, match="did not converge"):
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, max_iterations=1)
    with pytest.raises(EngineError, match="return runs"):
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, max_runs=2)
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.periodic_orbit(HOPPER, HOP, GUESS, max_runs=0)
    assert ei.value.field == "max_runs"


def test_sensitivity_of_a_motor_behaviour() -> None:
    """A motor torque has partial derivatives (its actuator's law); one that reverses past an
    angle (a torque jump without an event) has none: refused naming ``behaviour``."""
    def motor(**extra):
        return {
            "actuators": {"m": {"kind": "saturated", "max_torque_n_m": 2.0}},
            "joints": [{"joint": "leg[1]", "phases": [
                {"name": "a", "torque": {"kind": "motor", "actuator": "m", "command": 0.5, **extra}}]}],
        }
    e = selfmanip.simulate(HOPPER, motor(), GUESS, t_final=0.05, sensitivity=True)
    assert e.state_jacobian is not None
    with pytest.raises(InvalidInputError) as ei:
        selfmanip.simulate(HOPPER, motor(reverse_beyond_rad=0.3), GUESS, t_final=0.05, sensitivity=True)
    assert ei.value.field == "behaviour"


def test_example_runs(tmp_path: pathlib.Path, monkeypatch: pytest.MonkeyPatch,
                      capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    monkeypatch.setattr(sys, "argv", ["floquet_hopper.py", "--out-dir", str(tmp_path)])
    with pytest.raises(SystemExit) as ex:
        runpy.run_path(str(ROOT / "python" / "examples" / "floquet_hopper.py"), run_name="__main__")
    assert ex.value.code == 0
    out = capsys.readouterr().out
    assert "touchdown -> liftoff -> apex" in out and "stability: unstable" in out
    assert (tmp_path / "floquet_hopper.png").stat().st_size > 0


def test_a_behaviour_memory_of_the_start_state_is_differentiated():
    """A motion whose numbers use the state where it starts (``theta``) is a memory of that
    event the behaviour differentiates through its start; a hold at a constant angle started
    at the same event is no memory: both Jacobians come out (checked against central
    differences in crates/selfmanip-sim/tests/event_memory.rs)."""
    robot = {
        "name": "arm-on-a-block",
        "body": {"mass_kg": 2.0, "inertia_kg_m2": 0.05},
        "legs": [{"name": "arm", "hip_m": [0.1, 0.0], "links": [{"length_m": 0.1}]}],
        "contacts": [{"name": "belly", "shape": {"kind": "point", "position_m": [0.0, 0.05]},
                      "friction": {"kind": "sticking", "mu": 1.0}}],
    }

    def behaviour(angle):
        return {"name": "swing-at-touchdown", "joints": [{"joint": "arm[0]", "phases": [
            {"name": "air", "motion": {"kind": "hold", "angle_rad": 2.6}},
            {"name": "landed", "start": {"on": "touch", "contacts": ["belly"]},
             "motion": {"kind": "hold", "angle_rad": angle}}]}]}

    q0, qd0 = [2.6, 0.0, -0.2, 0.0], [0.0, 0.0, 0.5, 0.0]
    e = selfmanip.simulate(robot, behaviour("theta + 0.1"), q0, qd0, t_final=0.4, sensitivity=True)
    assert e.state_jacobian is not None
    e = selfmanip.simulate(robot, behaviour(3.0), q0, qd0, t_final=0.4, sensitivity=True)
    assert e.state_jacobian is not None
