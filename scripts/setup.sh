#!/usr/bin/env bash
# Checks and installs what building vadop needs on a Debian machine: a C linker (installed with
# apt-get when missing and run as root) and a Rust toolchain of the version rust-toolchain.toml
# pins. Rust is not a Debian package recent enough, so when cargo is missing this script says
# exactly how to install it with rustup and stops. With --mpi it also installs what vadop-mpi
# builds and runs with: Debian's OpenMPI (libopenmpi-dev, openmpi-bin) and libclang-dev for the
# bindings' generator (the test command asks for it; the main job does not need MPI). Safe to
# run again: it does nothing when everything is present.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

# Installs the Debian packages named in "$@" with apt-get (as root), or says how to.
install_packages() {
  if command -v apt-get >/dev/null 2>&1 && [ "$(id -u)" = 0 ]; then
    echo "setup: installing $* (apt-get)" >&2
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
  else
    echo "setup: missing $*: install them (on Debian: sudo apt-get install $*) and run again" >&2
    exit 1
  fi
}

if [ "${1:-}" = --mpi ]; then
  mpi=()
  command -v mpirun >/dev/null 2>&1 || mpi+=(openmpi-bin)
  command -v mpicc >/dev/null 2>&1 || mpi+=(libopenmpi-dev)
  # libclang itself (libclang.so, libclang-14.so.1), not libclang-cpp, which some images carry
  # without it and which the bindings' generator cannot load.
  compgen -G "/usr/lib/llvm-*/lib/libclang.so*" >/dev/null || compgen -G "/usr/lib/x86_64-linux-gnu/libclang-[0-9]*.so*" >/dev/null || mpi+=(libclang-dev)
  if [ ${#mpi[@]} -gt 0 ]; then
    install_packages "${mpi[@]}"
  fi
fi
if ! command -v cc >/dev/null 2>&1; then
  install_packages build-essential
fi
toolchain=$(sed -n 's/^channel *= *"\(.*\)"/\1/p' rust-toolchain.toml)
if ! command -v cargo >/dev/null 2>&1; then
  cat >&2 <<MSG
setup: cargo not found. vadop needs Rust $toolchain (pinned in rust-toolchain.toml). Install it with rustup:
    curl --proto '=https' --tlsv1.2 -sSf https://sh.rustup.rs | sh -s -- -y --default-toolchain $toolchain --profile minimal
then open a new shell (or run: . "\$HOME/.cargo/env") and run this command again.
MSG
  exit 1
fi
# rustup reads rust-toolchain.toml itself; a cargo without rustup must already be new enough.
if ! command -v rustup >/dev/null 2>&1; then
  have=$(rustc --version | cut -d' ' -f2)
  if [ "$(printf '%s\n%s\n' "$toolchain" "$have" | sort -V | head -n1)" != "$toolchain" ]; then
    echo "setup: rustc $have is older than the $toolchain that vadop is built and tested with; install Rust $toolchain with rustup (https://rustup.rs)" >&2
    exit 1
  fi
fi
