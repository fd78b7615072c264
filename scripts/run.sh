#!/usr/bin/env bash
# The main job: simulates the paper's scene and prints a readable summary.
# Any argument is passed to `vadop simulate` (see `vadop simulate --help`).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh
export PATH="$HOME/.cargo/bin:$PATH"
# The first run compiles the engine and the CLI (a few minutes on two cores): show cargo's
# progress on stderr so it is clear something is happening; later runs take a second.
if [ ! -x target/release/vadop ]; then
  echo "run: building vadop in release mode (first run only; cargo's progress follows)" >&2
fi
cargo build --release -p vadop-cli
exec ./target/release/vadop simulate "$@"
