#!/usr/bin/env python3
"""One thread against two, for one or two builds of the `vadop` CLI, alternating round by round.

Usage: python3 scripts/ab_threads.py OUT.jsonl ROUNDS N SPEED FRAMES DIR [DIR]

Each DIR holds a `vadop` binary. Every round runs each build on the paper scene in detect mode
(`vadop simulate --bodies N --max-speed SPEED --mode detect --frames FRAMES --reference none`)
with one thread pinned to core 1 (`taskset -c 1`) and then two threads on cores 0 and 1, so a
drift of the machine's speed hits every build and thread count alike. A run's figure is its
c_total per frame (the `ms` column of `--csv`) averaged over every frame, window starts
included. Prints, per build, each round's one- and two-thread times, their medians and the
speed-ups; with two builds, the second's time over the first's round by round. OUT.jsonl gets a
line per run (with the load average), so the runs can be read again.
"""
import csv
import json
import os
import statistics
import subprocess
import sys
import tempfile


def main():
    out, rounds, n, speed, frames = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
    builds = sys.argv[6:]
    if not 1 <= len(builds) <= 2:
        sys.exit(__doc__)
    times = {}
    with tempfile.TemporaryDirectory() as scratch, open(out, "a") as log:
        table = os.path.join(scratch, "frames.csv")
        for round_ in range(rounds):
            for build in builds:
                for threads, cpus in ((1, "1"), (2, "0,1")):
                    command = ["taskset", "-c", cpus, os.path.join(build, "vadop"), "simulate", "--bodies", n,
                               "--max-speed", speed, "--mode", "detect", "--frames", frames, "--reference", "none",
                               "--threads", str(threads), "--csv", table]
                    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                    rows = list(csv.DictReader(open(table)))
                    ms = sum(float(row["ms"]) for row in rows) / len(rows)
                    record = dict(build=build, n=n, speed=speed, threads=threads, round=round_, ms=ms,
                                  load=open("/proc/loadavg").read().split()[0])
                    log.write(json.dumps(record) + "\n")
                    log.flush()
                    times.setdefault((build, threads), []).append(ms)
    listed = lambda values: " ".join(f"{v:.2f}" for v in values)
    for build in builds:
        one, two = times[(build, 1)], times[(build, 2)]
        speedups = [a / b for a, b in zip(one, two)]
        print(f"{build}: 1 thread {listed(one)} (median {statistics.median(one):.2f}) | 2 threads {listed(two)} "
              f"(median {statistics.median(two):.2f}) | speed-up {listed(speedups)} (median {statistics.median(speedups):.2f})")
    if len(builds) == 2:
        base, new = builds
        for threads in (1, 2):
            ratios = [b / a for a, b in zip(times[(base, threads)], times[(new, threads)])]
            print(f"new / base, {threads} thread(s), round by round: {listed(ratios)}")


if __name__ == "__main__":
    main()
