"""``selfmanip.periodic_orbit`` through simultaneous landings (issue 30): the quadruped of
``crates/selfmanip-sim/examples/data/quadruped.toml`` with massless legs and its friction
declared, pronking under ``crates/selfmanip-sim/tests/data/pronk_periodic.toml`` (the hind
leg the fore leg's mirror image): both feet land together and lift off together. Independent
routes: the return map on the mirror-symmetric perturbations (where the guards' order does
not matter) against central differences of whole apex-to-apex ``simulate`` runs, its
multipliers against the finite-difference matrix's; and the one-sided liftoff derivatives of
``simulate(..., sensitivity=True)`` against the mirror symmetry.
"""

from __future__ import annotations

import pathlib
import tomllib

import numpy as np
import pytest

import selfmanip

ROOT = pathlib.Path(__file__).resolve().parents[2]
QUAD = ROOT / "crates" / "selfmanip-sim" / "examples" / "data" / "quadruped.toml"
PRONK = ROOT / "crates" / "selfmanip-sim" / "tests" / "data" / "pronk_periodic.toml"
GUESS = [0.5, -1.0, -0.5, 1.0, 0.0, -0.45, 0.0]
# every component to the same absolute tolerance: differences of whole runs resolve a
# derivative no better than each run's error
TIGHT = dict(rtol=1e-11, atol=1e-13, event_tol_s=1e-13, velocity_tolerance="uniform")


@pytest.fixture(scope="module")
def robot(tmp_path_factory: pytest.TempPathFactory) -> pathlib.Path:
    d = tomllib.loads(QUAD.read_text())
    for leg in d["legs"]:
        for link in leg["links"]:
            link["mass_kg"] = 0.0
            link["inertia_kg_m2"] = 0.0
    lines = [f'name = "{d["name"]}"', f'gravity_m_s2 = {d["gravity_m_s2"]}', "[body]",
             f'mass_kg = {d["body"]["mass_kg"]}', f'inertia_kg_m2 = {d["body"]["inertia_kg_m2"]}']
    for leg in d["legs"]:
        lines += ["[[legs]]", f'name = "{leg["name"]}"', f'hip_m = {leg["hip_m"]}']
        for link in leg["links"]:
            lines += ["[[legs.links]]", f'length_m = {link["length_m"]}', "mass_kg = 0.0", "inertia_kg_m2 = 0.0"]
    for c in d["contacts"]:
        pos = c["shape"]["position_m"]
        lines += ["[[contacts]]", f'name = "{c["name"]}"', f'leg = "{c["leg"]}"',
                  f'shape = {{ kind = "point", position_m = {pos} }}',
                  # declared: no test here depends on the description's default of mu_kinetic
                  'friction = { kind = "sticking", mu = 1.0, mu_kinetic = 1.0 }']
    p = tmp_path_factory.mktemp("pronk") / "quadruped_massless.toml"
    p.write_text("\n".join(lines) + "\n")
    return p


@pytest.fixture(scope="module")
def orbit(robot: pathlib.Path) -> selfmanip.PeriodicOrbit:
    return selfmanip.periodic_orbit(robot, PRONK, GUESS)


def _symmetric_basis(names: list[str]) -> np.ndarray:
    v = np.zeros((len(names), 5))
    pairs = [("fore[0]", "hind[0]"), ("fore[1]", "hind[1]")]
    col = 0
    for suffix in ("", "dot"):  # docs/conventions.md: `<joint>_theta`, `<joint>_thetadot`
        for a, b in pairs:
            ia, ib = names.index(f"{a}_theta{suffix}"), names.index(f"{b}_theta{suffix}")
            v[ia, col], v[ib, col] = 1.0, -1.0
            col += 1
    v[names.index("z"), 4] = 1.0
    return v


def test_pronk_orbit_symmetric_multipliers_match_finite_differences(
        robot: pathlib.Path, orbit: selfmanip.PeriodicOrbit) -> None:
    assert orbit.residual <= 1e-9
    assert [e["kind"] for e in orbit.events] == ["touchdown", "liftoff", "apex"]
    assert [e["kind"] for e in orbit.one_sided] == ["liftoff"]
    assert sorted(orbit.one_sided[0]["guards"]) == ["fore_foot", "hind_foot"]
    names = orbit.state_names
    v = _symmetric_basis(names)
    nq = len(orbit.q)
    proj = np.linalg.pinv(v)
    c = proj @ orbit.monodromy @ v

    def apex(x: np.ndarray) -> np.ndarray:
        e = selfmanip.simulate(robot, PRONK, list(x[:nq]), list(x[nq:]), t_final=2.0, stop_at="apex", **TIGHT)
        assert e.status == "apex"
        return np.concatenate([e.q_end, e.qd_end])

    def d(h: float) -> np.ndarray:
        return np.column_stack([(apex(orbit.x + h * v[:, k]) - apex(orbit.x - h * v[:, k])) / (2 * h)
                                for k in range(5)])

    h = 1e-5
    c_fd = proj @ ((4 * d(h / 2) - d(h)) / 3)
    mc = np.sort_complex(np.linalg.eigvals(c))
    mfd = np.sort_complex(np.linalg.eigvals(c_fd))
    assert np.max(np.abs(mc - mfd)) < 1e-5, (mc, mfd)
    assert all(np.min(np.abs(orbit.section_multipliers - m)) < 1e-8 for m in mc)


def test_one_sided_liftoff_in_simulate_is_mirror_symmetric(
        robot: pathlib.Path, orbit: selfmanip.PeriodicOrbit) -> None:
    nq = len(orbit.q)
    e = selfmanip.simulate(robot, PRONK, list(orbit.q), list(orbit.qd), t_final=2.0, stop_at="apex",
                           sensitivity=True, **TIGHT)
    lift = next(ev for ev in e.events if ev["kind"] == "liftoff")
    assert lift["saltation_status"] == "one_sided"
    assert "contacts" in lift["saltation_reason"]
    assert lift["saltation"] is None and e.state_jacobian is None
    assert e.one_sided_state_jacobian is not None
    a, b = lift["one_sided"]
    assert a["order"] == list(reversed(b["order"]))
    s = np.zeros((2 * nq, 2 * nq))
    for off in (0, nq):
        for i, j in ((0, 2), (1, 3), (2, 0), (3, 1)):
            s[off + i, off + j] = -1.0
        s[off + 4, off + 4], s[off + 5, off + 5], s[off + 6, off + 6] = -1.0, 1.0, -1.0
    xa, xb = np.asarray(a["saltation"]), np.asarray(b["saltation"])
    assert np.max(np.abs(xa - s @ xb @ s)) < 1e-9 * np.max(np.abs(xa))
    assert np.max(np.abs(xa - xb)) > 1e-3 * np.max(np.abs(xa))
