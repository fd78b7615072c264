#!/usr/bin/env bash
# Installs what `vadop-bench peers` needs beyond Rust: a C++ compiler, pkg-config, Debian's Bullet
# (libbullet-dev 3.24) and FCL (libfcl-dev 0.7) to build bench/peers/cpp, and taskset to pin the
# runs (the plot is drawn in Rust). Run as root on Debian; it does nothing when everything is
# present. `vadop-bench peers` itself only checks for them, so the benchmark never installs
# system packages.
set -euo pipefail
missing=()
[ -f /usr/include/bullet/btBulletCollisionCommon.h ] || missing+=(libbullet-dev)
[ -f /usr/include/fcl/fcl.h ] || missing+=(libfcl-dev)
command -v g++ >/dev/null 2>&1 && command -v make >/dev/null 2>&1 || missing+=(build-essential)
command -v pkg-config >/dev/null 2>&1 || missing+=(pkg-config)
command -v taskset >/dev/null 2>&1 || missing+=(util-linux)
if [ ${#missing[@]} = 0 ]; then
  echo "the peers' packages are all present"
  exit 0
fi
if ! command -v apt-get >/dev/null 2>&1; then
  echo "error: apt-get not found; install the equivalents of: ${missing[*]}" >&2
  exit 1
fi
if [ "$(id -u)" != 0 ]; then
  echo "error: missing ${missing[*]}; run this script as root (sudo $0)" >&2
  exit 1
fi
echo "installing ${missing[*]} with apt-get"
apt-get update -qq
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
