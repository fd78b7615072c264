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
(the event loop, inlined into `step`). The calls are counted from every file inlined into
`step` (the profile names `step` once per such file: the foresight's passes are called from
`pipeline/foreseen.rs`'s lines). The binning's count and scatter run inline in
`Grid::bin` on one thread but are shared on two; the second figure counts them serial too
(as the twelfth session gave it). Amdahl's bound for two cores follows from each.

Two threads (the serial loop per frame):
    valgrind --tool=callgrind --separate-threads=yes --callgrind-out-file=p2.cg vadop simulate \
        --bodies 100000 --max-speed 5 --mode detect --frames 4 --reference none --threads 2
    python3 scripts/serial_share.py --frames 4 p2.cg-02 p2.cg-03
(the workers' files, the CLI's own thread left out): the serial part of each thread's `step`
(the pipeline may run on either), summed, and both threads' instructions, per frame.
"""
import os
import re
import subprocess
import sys

PARALLEL = ["BroadPhase>::find_pairs", "BroadPhase>::prepare", "Grid::bin", "ProxyTable::refresh_all",
            "PassedContacts::resolve", "EventQueue::set_bulk", "Workers::extend_ranges",
            "PassedContacts::work_out_ahead", "foreseen::foresee_bounces"]


def tree(profile):
    command = ["callgrind_annotate", "--inclusive=yes", "--tree=calling", "--threshold=100", profile]
    return subprocess.run(command, capture_output=True, text=True, check=True).stdout.splitlines()


def blocks(lines, name):
    """Each entry of a function (the profile names one per source file inlined into it, the
    first with the whole function's inclusive count): its inclusive count and its callees' lines
    (count, text)."""
    entry = re.compile(r"\*  .*" + re.escape(name) + r"( \[|$)")
    for k, line in enumerate(lines):
        if entry.search(line):
            callees = []
            for callee in lines[k + 1:]:
                if not callee.strip():
                    break
                callees.append((int(callee.split()[0].replace(",", "")), callee))
            yield int(line.split()[0].replace(",", "")), callees


def block(lines, name):
    """A function's inclusive count and its callees' lines (count, text), from every entry."""
    found = list(blocks(lines, name))
    if not found:
        raise SystemExit(f"{name} not in the profile")
    return found[0][0], [callee for _, callees in found for callee in callees]


def threads(profiles, frames):
    """A two-thread run's serial part and all its instructions, per frame."""
    serial = total = 0
    for profile in profiles:
        lines = tree(os.path.abspath(profile))
        totals = [line for line in lines if "PROGRAM TOTALS" in line]
        total += int(totals[0].split()[0].replace(",", ""))
        if list(blocks(lines, "Pipeline<B>::step")):
            step, callees = block(lines, "Pipeline<B>::step")
            serial += step - sum(n for n, text in callees if any(p in text for p in PARALLEL))
    print(f"serial {serial / frames / 1e6:.2f} M a frame, "
          f"both threads {total / frames / 1e6:.1f} M a frame")


def main():
    if sys.argv[1] == "--frames":
        return threads(sys.argv[3:], int(sys.argv[2]))
    lines = tree(os.path.abspath(sys.argv[1]))
    # `Pipeline<B>::step` with whatever is inlined into it: the window start's foresight (its
    # parallel passes called from `pipeline/foreseen.rs`'s lines) is counted parallel too.
    step, callees = block(lines, "Pipeline<B>::step")
    parallel = sum(n for n, text in callees if any(p in text for p in PARALLEL))
    # The grid's `prepare` and `prepare_foreseen` (see pipeline::foreseen) both bin through
    # `Grid::bin`, which holds the count and scatter when it is not inlined into them.
    grid = any("*  " in line and "Grid::bin [" in line for line in lines)
    # Its first entry's calls only (as the twelfth session counted): those of its inlined files
    # hold the count and scatter's own closures.
    prepare, inside = next(blocks(lines, "Grid::bin" if grid else "BroadPhase>::prepare"))
    binning = prepare - sum(n for n, _ in inside)
    for n, text in callees:
        print(f"{n / 1e6:10.1f} M  {text.split(':', 1)[-1].split(' [')[0].strip()}")
    for label, serial in (("serial", step - parallel), ("with the binning's count and scatter", step - parallel + binning)):
        share = serial / step
        print(f"{label}: {serial / 1e6:.1f} M of {step / 1e6:.1f} M = {100 * share:.1f} %, "
              f"two cores at most {1 / (share + (1 - share) / 2):.2f}x")


if __name__ == "__main__":
    main()
