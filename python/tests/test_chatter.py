"""The (+,-) broad-sweep point whose front toe chattered at its friction cone's edge
(docs/decisions/2026-11-24-chatter-ends-as-zeno.md): several hundred touchdown/liftoff cycles until t_final, then ``zeno``
by the chatter detection. The cycle was the retracting leg's park planned anew at each
release; with one retraction per leg ("One retraction per leg") the toe lets go once and the
leap ends ``final_time`` without flying, like the rear-first (+,-) leaps around it. (The chatter's reason text is
no longer reached by a default leap; `crates/selfmanip-hybrid/tests/chatter.rs` covers the
detector.)"""

import selfmanip


def test_cone_edge_point_lets_go_once():
    r = selfmanip.leap(
        "+-",
        t2=-0.2303,
        gear_ratio=23.70,
        params={"m_b": 10.232834573074323, "I_b": 0.07836595626904441},
    )
    assert r.status == "final_time" and not r.flew
    assert "chatter" not in r.reason
    # before: about 580 events until t_final, then under 150 with the chatter detection
    assert len(r.events) < 30

