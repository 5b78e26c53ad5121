#!/usr/bin/env bash
# Regenerates docs/fidelity.md: each leap claim of the thesis's chapters 3 and 5, the default
# model's value and its verdict (crates/tools/src/bin/fidelity.rs; release build, ~1 min),
# and the same claims asked of other legs: docs/fidelity-massive-legs.md (Table 4.2's leg mass)
# and docs/fidelity-leg-rotors.md (massless links that carry their motors' rotors).
set -euo pipefail
cd "$(dirname "$0")/.."
cargo run --quiet --release -p selfmanip-tools --bin fidelity -- docs/fidelity.md
cargo run --quiet --release -p selfmanip-tools --bin fidelity -- docs/fidelity-massive-legs.md table-4.2
cargo run --quiet --release -p selfmanip-tools --bin fidelity -- docs/fidelity-leg-rotors.md rotors
