#!/usr/bin/env bash
# The API documentation with its math rendered (KaTeX, from docs/katex-header.html):
#   scripts/doc.sh [--open]      -> target/doc/selfmanip/index.html
set -euo pipefail
cd "$(dirname "$0")/.."
RUSTDOCFLAGS="--html-in-header $(pwd)/docs/katex-header.html" \
    cargo doc --no-deps --workspace --exclude selfmanip-pybind "$@"
