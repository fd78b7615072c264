#!/usr/bin/env bash
# Weak scaling of vadop-mpi on a cluster: `vadop-bench mpi` with the cluster's launcher, from one
# node's cores up to all of them, the same number of bodies on every rank. Run it from a shell
# that holds the allocation (e.g. `salloc -N 100 --ntasks-per-node 64 ./scripts/mpi-cluster.sh`):
#
#   RANKS       rank counts, comma-separated   [default: 64,512,1600,6400]
#   PER_RANK    bodies per rank                [default: 156250: 10^9 bodies on 6400 ranks]
#   LAUNCHER    how K ranks start, {ranks} for K [default: srun -n {ranks}]
#   FRAMES      frames per run                 [default: 60]
#
# The table, the CSV and the model go into BENCHMARKS.md and results/mpi/ of this checkout, as on
# one machine, without the one-process column (a billion bodies do not fit one node).
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/setup.sh --mpi
export PATH="$HOME/.cargo/bin:$PATH"
cargo build --release -p vadop-cli -p vadop-bench -p vadop-mpi
exec ./target/release/vadop-bench mpi \
  --ranks "${RANKS:-64,512,1600,6400}" \
  --bodies-per-rank "${PER_RANK:-156250}" \
  --frames "${FRAMES:-60}" \
  --launcher "${LAUNCHER:-srun -n {ranks}}" \
  --without-one-process \
  "$@"
