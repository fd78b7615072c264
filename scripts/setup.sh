#!/usr/bin/env bash
# Installs what vadop needs on a fresh Debian machine: a Rust toolchain (via rustup when cargo is
# missing) and a C linker. Safe to run again: it does nothing when everything is present.
set -euo pipefail
if ! command -v cc >/dev/null 2>&1; then
  if command -v apt-get >/dev/null 2>&1; then
    apt-get update -qq && apt-get install -y -qq build-essential >/dev/null
  fi
fi
if ! command -v cargo >/dev/null 2>&1; then
  [ -x "$HOME/.cargo/bin/cargo" ] || {
    echo "cargo not found: install Rust (https://rustup.rs) and run again" >&2
    exit 1
  }
fi
