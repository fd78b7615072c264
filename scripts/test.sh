#!/usr/bin/env bash
# Runs every test of the workspace: unit tests, property tests against the brute-force oracle,
# integration tests of the CLI and the documentation examples. Optimised build: the property
# tests step thousands of bodies over many frames.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$HOME/.cargo/bin:$PATH"
cargo test --release --workspace --all-targets
cargo test --release --workspace --doc
