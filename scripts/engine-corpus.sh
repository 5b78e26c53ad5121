#!/usr/bin/env bash
# The engine's behaviour corpus: 4,032 RHex leaps (four strategies × 21 t2 × flat and ledge
# terrains × both actuators × four robot variants, each stopped at its apex and continued to
# its landings), one JSON line each with exact bit patterns (crates/tools/src/bin/
# engine_corpus.rs). A change that must not alter the engine's behaviour leaves it identical.
#
#   scripts/engine-corpus.sh OUT.jsonl        run it on this checkout (release build, ~10 s)
#   scripts/engine-corpus.sh --compare A B    statuses of both, and every run that differs
#   scripts/engine-corpus.sh --compare --rename OLD=NEW[|NEW2],... A B
#                                             the same, A's statuses renamed first: a run of
#                                             A with status OLD matches B's run if B's status
#                                             is one of the NEWs and all else is equal
#   --rename leap-statuses                    the map from the leap's own statuses to the
#                                             engine's run statuses (corpora made before they
#                                             were one type)
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ "${1:-}" == "--compare" ]]; then
    rename=""
    if [[ "${2:-}" == "--rename" ]]; then
        rename="$3"
        shift 2
    fi
    if [[ "$rename" == "leap-statuses" ]]; then
        # `ok`: the apex it stopped at, or the final time it ran on to after a flight
        rename="ok=apex|final_time,no_flight=final_time,terrain_edge=terrain_discontinuity"
        rename+=",singular_contact=singular_flow"
    fi
    exec python3 - "$2" "$3" "$rename" <<'PY'
import collections, json, sys
a, b = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
rename = {}
for item in filter(None, sys.argv[3].split(",")):
    old, _, new = item.partition("=")
    rename[old] = set(new.split("|"))
if len(a) != len(b):
    sys.exit(f"different corpora: {len(a)} and {len(b)} runs")
if rename:
    print("renaming A's statuses: " + ", ".join(f"{k} -> {'|'.join(sorted(v))}" for k, v in rename.items()))
    # A's status takes B's name where the map allows it (any other stays and differs)
    for x, y in zip(a, b):
        if "status" in x and y.get("status") in rename.get(x["status"], ()):
            x["status"] = y["status"]
key = lambda d: (d["variant"], d["actuator"], d["terrain"], d["strategy"], d["t2"], d["stop_at_apex"])
for name, runs in (("A", a), ("B", b)):
    c = collections.Counter(d.get("status", "error") for d in runs)
    ev = sum(len(d.get("events", [])) for d in runs)
    print(f"{name}: {len(runs)} runs, {ev} events, " + ", ".join(f"{k} {v}" for k, v in sorted(c.items())))
diff = [(x, y) for x, y in zip(a, b) if x != y]
fields = collections.Counter(f for x, y in diff for f in set(x) | set(y) if x.get(f) != y.get(f))
print(f"{len(diff)} runs differ" + (": " + ", ".join(f"{f} in {n}" for f, n in fields.most_common()) if diff else ""))
for x, y in diff[:10]:
    print("  ", key(x), x.get("status"), x.get("word"), "->", y.get("status"), y.get("word"))
sys.exit(1 if diff else 0)
PY
fi
usage="usage: scripts/engine-corpus.sh OUT.jsonl | --compare [--rename MAP] A B"
out="${1:?$usage}"
if [[ "$out" == -* ]]; then
    echo "$usage" >&2  # an option it does not know (`--help`) is not an output file name
    [[ "$out" == "-h" || "$out" == "--help" ]] && exit 0 || exit 2
fi
cargo build --quiet --release -p selfmanip-tools --bin engine_corpus
./target/release/engine_corpus > "$out"
