#!/usr/bin/env bash
# Runs every test of the workspace: unit tests, property tests against the brute-force oracle,
# integration tests of the CLI and the documentation examples, then the Python package's. Each
# step says what it does before it starts and how long it took after, so a long one (the first
# build, installing chromium) is never silent. Optimised build: the property tests step
# thousands of bodies over many frames. Stops with a non-zero code at the first failure.
set -euo pipefail
cd "$(dirname "$0")/.."

# `step NAME COMMAND...`: runs COMMAND, NAME announced before and timed after.
step() {
  local name=$1 start=$SECONDS
  shift
  echo "test: $name" >&2
  "$@"
  echo "test: $name: done in $((SECONDS - start)) s" >&2
}

step "checking the toolchain and MPI for vadop-mpi (scripts/setup.sh --mpi; apt-get the first time)" ./scripts/setup.sh --mpi
export PATH="$HOME/.cargo/bin:$PATH"
# Hygiene first, so a formatting slip fails in seconds rather than after the long tests.
step "formatting (cargo fmt --check)" cargo fmt --all --check
step "layout (no import circle between the core's modules, no oversized file)" python3 scripts/check_layout.py
step "lints (cargo clippy; builds the workspace the first time: several minutes)" \
  cargo clippy --release --workspace --all-targets -- -D warnings
step "Rust tests (cargo test --all-targets)" cargo test --release --workspace --all-targets
# Debug assertions guard the engine's invariants, which the optimised build never checks: the
# periodic box, the oracle and the thread-count tests once more in a debug build (a few minutes).
step "debug assertions (the periodic, oracle and determinism tests in a debug build)" \
  cargo test -p vadop --test periodic --test oracle --test determinism
# The doctests include README.md's Rust examples (crates/vadop/src/lib.rs, ReadmeExamples).
step "doctests, the README's Rust examples included" cargo test --release --workspace --doc
step "API documentation (cargo doc, warnings are errors)" \
  env RUSTDOCFLAGS="-D warnings" cargo doc --release --workspace --no-deps
# The private items' doc comments too, so their links cannot rot (vadop-py's are Python
# docstrings, whose `x[0]` rustdoc would read as links: its public docs are checked above).
step "internal documentation (cargo doc --document-private-items, warnings are errors)" \
  env RUSTDOCFLAGS="-D warnings" cargo doc --release --workspace --exclude vadop-py --no-deps --document-private-items

# Python package: build and install it into a local virtual environment the way users do
# (`pip install ./`), with the test tools, then run its tests. The viewer test drives a real
# headless browser: install Debian's chromium when it is missing (CI runs as root on Debian).
install_chromium() {
  if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null
  else
    echo "note: chromium is missing and cannot be installed here; the viewer's browser test will be skipped" >&2
  fi
}
if ! command -v chromium >/dev/null 2>&1; then
  step "installing chromium for the viewer test (apt-get; a few minutes)" install_chromium
fi
make_venv() {
  python3 -m venv .venv || {
    # Debian's system Python keeps venv in a separate package.
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv >/dev/null
    python3 -m venv .venv
  }
}
if [ ! -x .venv/bin/python ]; then
  step "creating the Python virtual environment .venv" make_venv
fi
step "installing the Python test tools into .venv (pip)" \
  .venv/bin/python -m pip install -q --disable-pip-version-check maturin numpy pytest hypothesis matplotlib mypy pdoc

# The extension is rebuilt and reinstalled only when what goes into it changed: the engine and
# binding crates, the package's Python files, the build settings (README.md, the package's long
# description, is left out: the tests read it from the tree). The stamp is written only
# after an install succeeded, and lives in .venv, so a new environment always installs.
extension_inputs() {
  {
    find crates/vadop/src crates/vadop-py/src python/vadop -type f \
      -not -path '*/__pycache__/*' -not -name '*.so' -print0 | sort -z | xargs -0 sha256sum
    sha256sum crates/vadop/Cargo.toml crates/vadop-py/Cargo.toml pyproject.toml Cargo.toml Cargo.lock \
      rust-toolchain.toml
  } | sha256sum | cut -d' ' -f1
}
stamp=.venv/vadop-extension.sha256
inputs=$(extension_inputs)
if [ "$(cat "$stamp" 2>/dev/null)" = "$inputs" ] && .venv/bin/python -c "import vadop" 2>/dev/null; then
  echo "test: the Python extension is up to date (its inputs are unchanged since it was installed)" >&2
else
  step "building and installing the Python extension (pip install ./; a release build of the engine)" \
    .venv/bin/python -m pip install -q --disable-pip-version-check ./
  echo "$inputs" >"$stamp"
fi
step "Python tests (pytest)" .venv/bin/python -m pytest -q python/tests
step "Python API reference (scripts/python-docs.sh)" ./scripts/python-docs.sh
