#!/usr/bin/env bash
# The whole test suite, Rust and Python (what `.ci/run` runs).
#   1. every Rust crate's unit, integration and doc tests, plus each criterion benchmark
#      run once in test mode (so benchmarks cannot rot), in release: the numeric and
#      property tests are slow unoptimized;
#   2. the Python package built and installed with its test extra, then pytest.
# Works without a virtualenv: pip installs into the active interpreter.
set -euo pipefail
cd "$(dirname "$0")/.."
PY="${PYTHON:-python3}"

echo "== Rust tests (cargo test --workspace --release --all-targets)"
cargo test --workspace --release --all-targets

echo "== Python package (pip install .[test])"
"$PY" -m pip install --quiet --disable-pip-version-check ".[test]"

echo "== Python tests (pytest)"
"$PY" -m pytest -q python/tests
