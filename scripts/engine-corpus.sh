#!/usr/bin/env bash
# The engine's behaviour corpus: 4,032 RHex leaps (four strategies × 21 t2 × flat and ledge
# terrains × both actuators × four robot variants, each stopped at its apex and continued to
# its landings), one JSON line each with exact bit patterns (crates/tools/src/bin/
# engine_corpus.rs). A change that must not alter the engine's behaviour leaves it identical.
#
#   scripts/engine-corpus.sh OUT.jsonl        run it on this checkout (release build, ~10 s)
#   scripts/engine-corpus.sh --compare A B    statuses of both, and every run that differs
set -euo pipefail
cd "$(dirname "$0")/.."
if [[ "${1:-}" == "--compare" ]]; then
    exec python3 - "$2" "$3" <<'PY'
import collections, json, sys
a, b = ([json.loads(l) for l in open(p)] for p in sys.argv[1:3])
if len(a) != len(b):
    sys.exit(f"different corpora: {len(a)} and {len(b)} runs")
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
out="${1:?usage: scripts/engine-corpus.sh OUT.jsonl | --compare A B}"
cargo build --quiet --release -p selfmanip-tools --bin engine_corpus
./target/release/engine_corpus > "$out"
