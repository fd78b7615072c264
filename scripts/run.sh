#!/usr/bin/env bash
# The main job: simulates the paper's scene and prints a readable summary.
# Any argument is passed to `vadop simulate` (see `vadop simulate --help`).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$HOME/.cargo/bin:$PATH"
cargo build --release -q -p vadop-cli
exec ./target/release/vadop simulate "$@"
