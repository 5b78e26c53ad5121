"""The ground reaction complex as Python data, checked against counts derived here."""

import itertools

from selfmanip.rhex import ground_reaction_complex


def test_grc_counts_and_structure():
    g = ground_reaction_complex()
    labels = ["".join(b) for b in itertools.product("01", repeat=4)]
    assert sorted(c["label"] for c in g["cells"]) == labels
    pairs = {(a, b) for a in labels for b in labels if sum(x != y for x, y in zip(a, b)) == 1}
    assert {(t["from"], t["to"]) for t in g["hasse"]} == pairs and len(pairs) == 64
    allowable = {(t["from"], t["to"]) for t in g["allowable"]}
    assert len(allowable) == 18 and allowable <= pairs
    assert {t["category"] for t in g["allowable"]} == {"control_triggered", "state_triggered"}
    for w in g["leap_words"]:
        path = w["path"]
        assert path[0] == "1010" and path[-1] == "0000"
        assert all((a, b) in allowable for a, b in zip(path, path[1:]))
    assert g["strategies"] == ["++", "+-", "-+", "--"]
