"""The chatter of the (+,-) front toe at its friction cone's edge (docs/leap-physics.md):
a broad-sweep point that ran several hundred touchdown/liftoff cycles until t_final now ends
as ``zeno`` with a reason that names the chatter, after a bounded number of events."""

import selfmanip


def test_cone_edge_chatter_ends_as_zeno_with_its_reason():
    r = selfmanip.leap(
        "+-",
        t2=-0.2303,
        gear_ratio=23.70,
        params={"m_b": 10.232834573074323, "I_b": 0.07836595626904441},
    )
    assert r.status == "zeno"
    assert "chatter" in r.reason and "cycle of 3 events" in r.reason
    # before the detection: about 580 events until t_final
    assert len(r.events) < 150
