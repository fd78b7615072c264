#!/usr/bin/env bash
# Builds the old engine's `vadop` (commit d35de4a: the grid before the frame pipeline), which
# `vadop-bench speed` runs as the "old grid" column, and copies it to target/baseline/vadop-d35de4a.
# The commit is checked out with `git worktree add` in a scratch folder outside the repository
# (default: $TMPDIR/vadop-baseline-d35de4a, or the first argument) and built there with its own
# Cargo.lock and target folder; a second run reuses both. Remove it with
# `git worktree remove <folder>`.
set -euo pipefail
commit=d35de4a
repo="$(cd "$(dirname "$0")/.." && pwd)"
scratch="${1:-${TMPDIR:-/tmp}/vadop-baseline-$commit}"
case "$scratch" in
  "$repo"|"$repo"/*) echo "error: the scratch folder must lie outside the repository ($repo)" >&2; exit 2 ;;
esac
export PATH="$HOME/.cargo/bin:$PATH"
if [ ! -e "$scratch/.git" ]; then
  git -C "$repo" worktree add --detach "$scratch" "$commit"
fi
if [ "$(git -C "$scratch" rev-parse --short=7 HEAD)" != "$commit" ]; then
  echo "error: $scratch is not a checkout of $commit; remove it or pass another folder" >&2
  exit 2
fi
cargo build --release --locked -p vadop-cli --manifest-path "$scratch/Cargo.toml"
mkdir -p "$repo/target/baseline"
cp "$scratch/target/release/vadop" "$repo/target/baseline/vadop-$commit"
echo "built $repo/target/baseline/vadop-$commit"
