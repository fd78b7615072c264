#!/usr/bin/env bash
# Runs every test of the workspace: unit tests, property tests against the brute-force oracle,
# integration tests of the CLI and the documentation examples. Optimised build: the property
# tests step thousands of bodies over many frames.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$HOME/.cargo/bin:$PATH"
# Hygiene first, so a formatting slip fails in seconds rather than after the long tests.
cargo fmt --all --check
cargo clippy --release --workspace --all-targets -- -D warnings
cargo test --release --workspace --all-targets
# The doctests include README.md's Rust examples (crates/vadop/src/lib.rs, ReadmeExamples).
cargo test --release --workspace --doc
RUSTDOCFLAGS="-D warnings" cargo doc --release --workspace --no-deps

# Python package: build and install it into a local virtual environment the way users do
# (`pip install ./`), with the test tools, then run its tests. The viewer test drives a real
# headless browser: install Debian's chromium when it is missing (CI runs as root on Debian).
if ! command -v chromium >/dev/null 2>&1; then
  if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  else
    echo "note: chromium is missing and cannot be installed here; the viewer's browser test will be skipped" >&2
  fi
fi
if [ ! -x .venv/bin/python ]; then
  python3 -m venv .venv || {
    # Debian's system Python keeps venv in a separate package.
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    python3 -m venv .venv
  }
fi
.venv/bin/python -m pip install -q --disable-pip-version-check maturin numpy pytest hypothesis matplotlib mypy pdoc
.venv/bin/python -m pip install -q --disable-pip-version-check ./
.venv/bin/python -m pytest -q python/tests
./scripts/python-docs.sh
