#!/usr/bin/env bash
# Whether the machine's first two cores share execution units (hyperthreads of one core): a
# compute-bound loop (four multiply-add chains in registers, no memory traffic) alone on core 1,
# then one copy on each of cores 0 and 1 at once, three times. Two independent cores take the
# same time both ways; two hyperthreads of one core take up to twice as long at once.
# Usage: scripts/core_sharing.sh (needs a C compiler; writes only under a temporary folder).
set -euo pipefail
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cat > "$work/spin.c" <<'C'
#include <stdio.h>
#include <stdlib.h>
int main(int argc, char **argv) {
    long n = argc > 1 ? atol(argv[1]) : 400000000L;
    double a = 1.0, b = 1.1, c = 1.2, d = 1.3;
    for (long i = 0; i < n; i++) {
        a = a * 0.9999999 + 1e-9; b = b * 0.9999998 + 2e-9;
        c = c * 0.9999997 + 3e-9; d = d * 0.9999996 + 4e-9;
    }
    printf("%g\n", a + b + c + d);
    return 0;
}
C
cc -O2 -o "$work/spin" "$work/spin.c"
seconds() { python3 -c 'import time; print(time.monotonic())'; }
for round in 1 2 3; do
  start=$(seconds); taskset -c 1 "$work/spin" > /dev/null; alone=$(python3 -c "print(f'{$(seconds) - $start:.3f}')")
  start=$(seconds)
  taskset -c 0 "$work/spin" > /dev/null & taskset -c 1 "$work/spin" > /dev/null; wait
  both=$(python3 -c "print(f'{$(seconds) - $start:.3f}')")
  echo "round $round: alone ${alone} s, one on each core at once ${both} s (load $(cut -d' ' -f1 /proc/loadavg))"
done
