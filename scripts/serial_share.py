#!/usr/bin/env python3
"""The serial share of the frame pipeline, from a one-thread callgrind profile.

Usage (from /tmp, so callgrind_annotate keeps whole paths):
    valgrind --tool=callgrind --callgrind-out-file=p.cg vadop simulate --bodies 100000 \
        --max-speed 5 --mode detect --frames 6 --reference none --threads 1
    python3 scripts/serial_share.py p.cg

The instructions of `Pipeline<B>::step` (inclusive) are split in two: those inside the calls
that share their work among the workers (the pair sweep, the binning, the proxies' refresh, the
bulk events' sort, the window start's wall predictions and foreseen bounces, the passing pairs'
geometry), and the rest, which one thread runs whatever the thread count
(the event loop, inlined into `step`). The binning's count and scatter run inline in
`Grid::bin` on one thread but are shared on two; the second figure counts them serial too
(as the twelfth session gave it). Amdahl's bound for two cores follows from each.
"""
import os
import subprocess
import sys

PARALLEL = ["BroadPhase>::find_pairs", "BroadPhase>::prepare", "Grid::bin", "ProxyTable::refresh_all",
            "PassedContacts::resolve", "EventQueue::set_bulk", "Workers::extend_ranges",
            "PassedContacts::work_out_ahead"]


def tree(profile):
    command = ["callgrind_annotate", "--inclusive=yes", "--tree=calling", "--threshold=100", profile]
    return subprocess.run(command, capture_output=True, text=True, check=True).stdout.splitlines()


def block(lines, name):
    """A function's inclusive count and its callees' lines (count, text)."""
    for k, line in enumerate(lines):
        if "*  " in line and name in line:
            callees = []
            for callee in lines[k + 1:]:
                if not callee.strip():
                    break
                callees.append((int(callee.split()[0].replace(",", "")), callee))
            return int(line.split()[0].replace(",", "")), callees
    raise SystemExit(f"{name} not in the profile")


def main():
    lines = tree(os.path.abspath(sys.argv[1]))
    step, callees = block(lines, "Pipeline<B>::step [")
    parallel = sum(n for n, text in callees if any(p in text for p in PARALLEL))
    # The grid's `prepare` and `prepare_foreseen` (see pipeline::foreseen) both bin through
    # `Grid::bin`, which holds the count and scatter when it is not inlined into them.
    grid = any("*  " in line and "Grid::bin [" in line for line in lines)
    prepare, inside = block(lines, "Grid::bin [" if grid else "BroadPhase>::prepare [")
    binning = prepare - sum(n for n, _ in inside)
    for n, text in callees:
        print(f"{n / 1e6:10.1f} M  {text.split(':', 1)[-1].split(' [')[0].strip()}")
    for label, serial in (("serial", step - parallel), ("with the binning's count and scatter", step - parallel + binning)):
        share = serial / step
        print(f"{label}: {serial / 1e6:.1f} M of {step / 1e6:.1f} M = {100 * share:.1f} %, "
              f"two cores at most {1 / (share + (1 - share) / 2):.2f}x")


if __name__ == "__main__":
    main()
