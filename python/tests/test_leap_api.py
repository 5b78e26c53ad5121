"""selfmanip.leap / selfmanip.sweep: shapes and dtypes, determinism across thread counts,
per-point failure isolation, agreement between a sweep row and the same leap run alone, the
grid order against itertools.product, and bad input naming its field."""

import itertools
import math

import numpy as np
import pytest

import selfmanip
from selfmanip.leap import SWEEP_COLUMNS, sweep_points, sweepable_names

T2 = np.linspace(-0.15, 0.15, 7)
FLOAT_COLUMNS = ("t2_s", "gear_ratio", "apex_z_m", "apex_x_m", "apex_phi_rad", "apex_xdot_m_s",
                 "apex_phidot_rad_s", "apex_zdot_m_s", "apex_t_s")


@pytest.fixture(scope="module")
def table():
    return selfmanip.sweep(["++", "+-", "-+", "--"], t2=T2, gear_ratio=[22.0, 28.0], threads=2)


@pytest.fixture(scope="module")
def one_leap():
    return selfmanip.leap("++", t2=0.0, gear_ratio=28.0, dt=0.002)


def bits(a):
    a = np.asarray(a)
    return a.view(np.int64) if a.dtype == np.float64 else a


def test_columns_shapes_and_dtypes(table):
    n = 4 * 2 * len(T2)
    assert list(table) == list(SWEEP_COLUMNS)
    for k, v in table.items():
        assert isinstance(v, np.ndarray) and v.shape == (n,), k
    for k in FLOAT_COLUMNS:
        assert table[k].dtype == np.float64, k
    for k in ("strategy", "word", "status", "error"):
        assert table[k].dtype.kind == "U", k
    assert table["n_events"].dtype == np.int64


def test_grid_order_matches_itertools_product(table):
    want = list(itertools.product(["++", "+-", "-+", "--"], [22.0, 28.0], T2))
    got = list(zip(table["strategy"], table["gear_ratio"], table["t2_s"]))
    assert got == want


def test_bit_identical_for_any_thread_count(table):
    for threads in (1, 3):
        other = selfmanip.sweep(["++", "+-", "-+", "--"], t2=T2, gear_ratio=[22.0, 28.0], threads=threads)
        for k in table:
            assert np.array_equal(bits(table[k]), bits(other[k])), (threads, k)


def test_progress_chunks_do_not_change_results(table):
    seen = []
    chunked = selfmanip.sweep(["++", "+-", "-+", "--"], t2=T2, gear_ratio=[22.0, 28.0], threads=2,
                              progress=seen.append)
    assert seen[-1] == len(table["t2_s"]) and seen == sorted(seen)
    for k in table:
        assert np.array_equal(bits(table[k]), bits(chunked[k])), k


def run_alone(strategy, t2, gear_ratio, **kw):
    """``(status, word, n_events, apex or None, error message)`` of one leap: an engine error
    of a single leap is an exception, in a sweep the row's status and message; a leap that
    does not fly has its reason, in a sweep the row's ``error``."""
    try:
        r = selfmanip.leap(strategy, t2=t2, gear_ratio=gear_ratio, dt=None, **kw)
    except selfmanip.SelfmanipError as e:
        return None, "", 0, None, str(e)
    assert (r.reason == "") == r.flew
    return r.status, r.word, len(r.events), r.apex, r.reason


def assert_row_equals_alone(table, i, **kw):
    gear = float(table["gear_ratio"][i])
    status, word, n_events, apex, error = run_alone(str(table["strategy"][i]), float(table["t2_s"][i]),
                                                    None if math.isnan(gear) else gear, **kw)
    assert table["error"][i] == error
    if status is None:
        assert table["status"][i] != "" and not table["flew"][i]
        return
    assert (table["status"][i], table["word"][i], table["n_events"][i]) == (status, word, n_events)
    if apex is None:
        assert math.isnan(table["apex_z_m"][i])
    else:
        assert (apex.z_m, apex.x_m, apex.phi_rad, apex.xdot_m_s, apex.phidot_rad_s) == (
            table["apex_z_m"][i], table["apex_x_m"][i], table["apex_phi_rad"][i],
            table["apex_xdot_m_s"][i], table["apex_phidot_rad_s"][i])


def test_sweep_row_equals_the_leap_run_alone(table):
    for i in (0, 9, 20, 33, 50):
        assert_row_equals_alone(table, i)


def test_a_failing_point_never_loses_the_others():
    good = dict(strategy=["++", "--", "++"], t2=[0.0, 0.05, -0.05], gear_ratio=28.0, m_b=[9.0, 9.0, 9.0])
    bad = dict(strategy=["++", "--", "-+", "++"], t2=[0.0, 0.05, 0.0, -0.05], gear_ratio=28.0,
               m_b=[9.0, 9.0, -1.0, 9.0])
    g = selfmanip.sweep(**good, grid=False, threads=2)
    b = selfmanip.sweep(**bad, grid=False, threads=2)
    assert b["status"][2] == "invalid_params" and "m_b" in b["error"][2]
    assert math.isnan(b["apex_z_m"][2]) and b["word"][2] == ""
    keep = [0, 1, 3]
    for k in g:
        assert np.array_equal(bits(g[k]), bits(b[k][keep])), k


def test_pandas_dataframe_just_works(table):
    pd = pytest.importorskip("pandas")
    df = pd.DataFrame(table)
    assert list(df.columns) == list(table) and len(df) == len(table["t2_s"])


def test_swept_parameters_become_columns_and_reach_the_model():
    r = selfmanip.sweep("++", t2=0.0, gear_ratio=28.0, m_b=[8.0, 10.0], leg_shape=["half_circle", "stick"])
    assert list(r["m_b"]) == [8.0, 8.0, 10.0, 10.0]
    assert list(r["leg_shape"]) == ["half_circle", "stick", "half_circle", "stick"]
    for i in range(4):
        alone = selfmanip.leap("++", 0.0, 28.0, params={"m_b": float(r["m_b"][i]), "leg_shape": str(r["leg_shape"][i])},
                               dt=None)
        assert alone.params["m_b"] == r["m_b"][i] and alone.params["leg_shape"] == r["leg_shape"][i]
        assert (alone.status, alone.word) == (r["status"][i], r["word"][i])


def test_pairs_choose_the_pushing_legs():
    # chapter 3's (+,−) pushes with the front and rear pairs; ``pairs`` picks others, and the
    # leap's robot then has those legs (its contacts are named after them)
    default = selfmanip.leap("+-", 0.1, 28.0, dt=0.01)
    chosen = selfmanip.leap("+-", 0.1, 28.0, params={"pairs": ["middle", "rear"]}, dt=0.01)
    assert {"front_leg", "rear_leg"} <= set(default.trajectory.contacts)
    assert {"middle_leg", "rear_leg"} <= set(chosen.trajectory.contacts)
    assert "front_leg" not in chosen.trajectory.contacts
    assert default.params["pairs"] == ["front", "rear"] and chosen.params["pairs"] == ["middle", "rear"]
    for pairs, alone in ((["front", "rear"], default), (["middle", "rear"], chosen)):
        swept = selfmanip.sweep("+-", t2=[0.1], gear_ratio=28.0, params={"pairs": pairs})
        assert swept["word"][0] == alone.word


@pytest.mark.filterwarnings("ignore::selfmanip.AllPointsFailedWarning")
def test_saturated_torque_reports_nan_gear_ratio():
    r = selfmanip.sweep("++", t2=[0.0, 0.1], gear_ratio=None)
    assert np.isnan(r["gear_ratio"]).all()
    for i in range(2):
        assert_row_equals_alone(r, i)


def test_leap_result_shapes(one_leap):
    r = one_leap
    tr = r.trajectory
    n, nq = tr.q.shape
    assert nq == len(r.q_names) == len(r.q0) == 5
    assert tr.qd.shape == (n, nq) and tr.t_s.shape == (n,) and len(tr.mode) == n
    assert tr.contact_points_m.shape == tr.contact_forces_n.shape == (n, len(tr.contacts), 2)
    assert r.cells[0] == "1010" and r.word == "-".join(r.cells)
    for e in r.events:
        assert set(e) == {"t_s", "kind", "mode_before", "mode_after", "contacts", "energy_loss_j",
                          "impulse_n_s", "force_n"}
    # inactive contacts have NaN points exactly where they have NaN forces
    assert np.array_equal(np.isnan(tr.contact_points_m), np.isnan(tr.contact_forces_n))


def test_apex_agrees_with_the_trajectory(one_leap):
    r = one_leap
    if not r.flew:
        pytest.skip(f"leap status {r.status}")
    tr = r.trajectory
    ix, iz, iphi = r.q_names.index("x"), r.q_names.index("z"), r.q_names.index("phi")
    # the last sample is the apex; the apex frame is z up with its origin at the start
    assert tr.t_s[-1] == pytest.approx(r.apex.t_s, abs=1e-12)
    assert r.apex.x_m == pytest.approx(tr.q[-1, ix] - r.q0[ix], abs=1e-9)
    assert r.apex.z_m == pytest.approx(-tr.q[-1, iz], abs=1e-9)
    assert r.apex.phi_rad == pytest.approx(tr.q[-1, iphi], abs=1e-9)
    assert r.apex.zdot_m_s == pytest.approx(0.0, abs=1e-6)
    assert r.cells[-1] == "0000" and tr.mode[-1] == "0000"


@pytest.mark.parametrize("kwargs, field", [
    (dict(strategy="+x"), "strategy"),
    (dict(strategy="+++"), "strategy"),
    (dict(t2=float("nan")), "t2"),
    (dict(gear_ratio=-3.0), "gear_ratio"),
    (dict(params={"rho2": 0.0}), "rho2"),
    (dict(params={"m_b": -1.0}), "m_b"),
    (dict(params={"leg_shape": "triangle"}), "leg_shape"),
    (dict(params={"mass": 1.0}), "mass"),
    (dict(current_limit_a=-1.0), "current_limit_a"),
    # a ledge's face within the robot's reach at the start (body end 0.255 m ahead)
    (dict(terrain={"kind": "ledge", "height_m": 0.2, "distance_m": 0.25}), "terrain.distance_m"),
    (dict(terrain={"kind": "ledge", "height_m": 0.2, "distance_m": 0.0}), "terrain.distance_m"),
])
def test_bad_leap_input_raises_value_error_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field) as e:
        selfmanip.leap(**{"dt": None, **kwargs})
    assert isinstance(e.value, selfmanip.SelfmanipError) and e.value.field == field


@pytest.mark.parametrize("kwargs, field", [
    (dict(delta_t_s="soon"), "delta_t_s"),
    (dict(stop_at_apex=1.0), "stop_at_apex"),
    (dict(terrain="ledge"), "terrain"),
    (dict(params={"m_b": "heavy"}), "m_b"),
    (dict(strategy=3), "strategy"),
])
def test_wrongly_typed_leap_input_raises_type_error_naming_the_field(kwargs, field):
    with pytest.raises(TypeError, match=field) as e:
        selfmanip.leap(**{"dt": None, **kwargs})
    assert isinstance(e.value, selfmanip.InvalidTypeError) and e.value.field == field


@pytest.mark.parametrize("kwargs, field", [
    (dict(strategy=["++", "-x"]), "strategy"),
    (dict(t2=[0.0, float("inf")]), "t2"),
    (dict(gear_ratio=[28.0, 0.0]), "gear_ratio"),
    (dict(params={"m_b": -1.0}), "m_b"),
    (dict(no_such_parameter=[1.0, 2.0]), "no_such_parameter"),
    (dict(threads=0), "threads"),
    (dict(m_b=[1.0, float("nan")]), "m_b"),
])
def test_bad_sweep_input_raises_value_error_naming_the_field(kwargs, field):
    with pytest.raises(ValueError, match=field):
        selfmanip.sweep(**{"t2": [0.0], **kwargs})


def test_zip_mode_requires_equal_lengths():
    with pytest.raises(ValueError, match="same length"):
        sweep_points("++", t2=[0.0, 0.1], gear_ratio=[20.0, 25.0, 30.0], grid=False)
    cols = sweep_points(["++", "--"], t2=[0.0, 0.1], gear_ratio=28.0, grid=False)
    assert cols["actuator"] == [28.0, 28.0] and cols["strategy"] == ["++", "--"]


def test_sweepable_names_cover_the_issue():
    names = set(sweepable_names())
    assert {"leg_shape", "m_b", "I_b", "m_l", "delta_t_s", "mu_front", "mu_middle", "mu_rear"} <= names
    assert not {"strategy", "t2_s", "actuator"} & names


def test_optional_parameters_reach_the_leap():
    """Fields that are unset by default (``mu_body``, ``leg_armature_kg_m2``) are parameters
    too, and a value given reaches the robot: a massless leg with armature is no longer a
    free massless joint, so the leap changes; a bad value names its field."""
    assert {"mu_body", "leg_armature_kg_m2", "toe_sliding"} <= set(sweepable_names())
    base = selfmanip.leap("--", t2=-0.02)
    rotors = selfmanip.leap("--", t2=-0.02, params={"leg_armature_kg_m2": 0.0112})
    assert rotors.params["leg_armature_kg_m2"] == 0.0112
    assert rotors.word != base.word
    with pytest.raises(ValueError, match="leg_armature_kg_m2"):
        selfmanip.leap("++", params={"leg_armature_kg_m2": -1.0})


def test_leg_rotors_follow_the_gear_ratio():
    """``leg_rotors=True`` gives massless links their motors' rotors, ``n J G^2`` of the
    leap's own gear ratio: the leap is bit-identical to one with that armature set by hand,
    the value scaled by ``G^2`` from 28:1 (the armature's definition); with both set, a
    ValueError names ``leg_rotors``."""
    assert "leg_rotors" in set(sweepable_names())
    # Table 2.1's X-RHex motor: J = tau_m k^2 / R with R = V / I_max (the 20 A limit binding at
    # stall), two motors per planar leg
    tau_m, k, r = 0.0118, 0.670 / 20.0, 37.0 / 20.0
    n_j = 2 * tau_m * k * k / r
    a28 = selfmanip.leap("--", t2=-0.02, params={"leg_rotors": True})
    for g in (28.0, 40.0):
        by_rotors = selfmanip.leap("--", t2=-0.02, gear_ratio=g, params={"leg_rotors": True})
        by_hand = selfmanip.leap("--", t2=-0.02, gear_ratio=g,
                                 params={"leg_armature_kg_m2": n_j * g * g})
        assert by_rotors.word == by_hand.word
        assert by_rotors.apex.z_m == pytest.approx(by_hand.apex.z_m, rel=1e-6, abs=0.0)
        assert by_rotors.apex.phi_rad == pytest.approx(by_hand.apex.phi_rad, rel=1e-6, abs=0.0)
    assert a28.word != selfmanip.leap("--", t2=-0.02).word
    with pytest.raises(ValueError, match="leg_rotors"):
        selfmanip.leap("++", params={"leg_rotors": True, "leg_armature_kg_m2": 0.01})


def test_docstring_examples():
    import doctest
    import sys

    mod = sys.modules["selfmanip.leap"]  # the attribute `selfmanip.leap` is the function

    res = doctest.testmod(mod, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert res.failed == 0 and res.attempted > 0


def test_massive_legs_run_with_coulomb_toes_and_a_painleve_end_is_typed():
    """Table 4.2's leg-pair mass with the default Coulomb toes (once a typed error: the core
    resolved kinetic friction only on massless legs). A massive leg alone on a slipping toe can
    meet Painlevé's paradox (its sliding mode has no or several solutions): the leap ends
    ``singular_flow`` with a reason that names the contact, never a number or a panic."""
    legs = {"m_l": 0.126, "I_l": 0.00092}
    r = selfmanip.leap("++", t2=0.0, params=legs)
    assert r.status == "apex" and r.flew and r.apex is not None
    # (the legs carry their rotors' reflected inertia: "-+" at t2 = 0, this test's case
    # before, now flies; so does "+-" at t2 = -0.03, its case after, through a Coulomb
    # impact at the front toe's touchdown (docs/singular-transitions.md, section 8))
    r = selfmanip.leap("+-", t2=-0.03, params=legs)
    assert r.status == "apex" and any(e["kind"] == "jam" for e in r.events)
    # chapter 3's saturated torque, (-,-) at t2 = 0.05: the middle toe touching down while
    # the front toe holds alone has two Coulomb-impact outcomes; the end stays typed
    r = selfmanip.leap("--", t2=0.05, gear_ratio=None, params={"m_l": 0.126})
    assert r.status == "singular_flow"
    assert "Painlevé" in r.reason and "`front_leg`" in r.reason


def test_leg_armature_is_a_sensitivity_parameter_of_legs_that_have_it():
    """``leg_armature_kg_m2`` is a sensitivity parameter of legs with armature (here massless
    links carrying an armature set by hand): the apex height's derivative equals central
    differences of whole leaps (tight tolerances), through the legs' motions in the air
    started at their liftoffs (the controller's memory); for massless legs without armature
    it is a ValueError naming the field."""
    a = 0.0112
    tight = dict(rtol=1e-12, event_tol_s=1e-14, control_free_joints=True)
    res = selfmanip.leap("--", t2=-0.1, params={"leg_armature_kg_m2": a},
                         sensitivities=["leg_armature_kg_m2"], **tight)
    assert res.sensitivity_ok, res.sensitivity_reason
    exact = res.sensitivity[("apex_z_m", "leg_armature_kg_m2")]
    h = 1e-6
    z = [selfmanip.leap("--", t2=-0.1, params={"leg_armature_kg_m2": a + s}, **tight).apex.z_m
         for s in (h, -h)]
    assert exact == pytest.approx((z[0] - z[1]) / (2 * h), rel=1e-4)
    with pytest.raises(ValueError, match="leg_armature_kg_m2"):
        selfmanip.leap("++", sensitivities=["leg_armature_kg_m2"])


def test_every_leap_reports_the_motor_start_it_ran_with():
    """A motor-timed leap ran with its own t2; a touchdown-timed one reports the motor start
    its search found, and with it the rear leg touches down t2 after the front leg (to the
    search's tolerance, 1e-7 s), which a motor-timed leap at that start reproduces."""
    plain = selfmanip.leap("++", t2=0.03, gear_ratio=28.0, dt=None)
    assert plain.motor_t2_s == 0.03
    timed = selfmanip.leap("++", t2=0.03, gear_ratio=28.0, dt=None, t2_reference="touchdown")
    assert abs(timed.touchdown_t2_s - 0.03) < 1e-7
    again = selfmanip.leap("++", t2=timed.motor_t2_s, gear_ratio=28.0, dt=None)
    assert again.word == timed.word
    assert again.touchdown_t2_s == timed.touchdown_t2_s
