#!/usr/bin/env python3
"""Before and after: two builds of the `vadop` CLI run alternately on the same commands.

Usage: python3 scripts/ab_runs.py BASE NEW OUT.json [detect] [gas] [shapes]

BASE and NEW are two `vadop` binaries (e.g. one built at an older commit in a git worktree, and
this one). Every case runs BASE then NEW, REPS times (3 unless the environment says otherwise;
ONLY=TEXT keeps the cases whose name, as printed, contains TEXT, e.g. ONLY='packing=0.4'),
each run a child pinned to core 1 with taskset, so that a drift of the machine's speed hits
both builds alike; read the ratios of each pair, not one absolute time. The figures come from
the per-frame CSV (`--csv`): c_total per frame (the `ms` column) and pair collisions per second
of it, after the warm-up frames, and ms per 1000 contacts. Each run prints one JSON line;
OUT.json gets them all. In detect mode both builds must report the same contacts, or the
comparison is void: the script stops then. In simulate mode a change that moves contact times
within the tolerance (bit-identical across methods still) sends the paths apart, so the contacts
may differ there: read ms per 1000 contacts beside ms per frame.

Cases: `detect` is the paper scene in detect mode at n = 1e4 and 1e5 and 0.05, 0.5 and 5 diameters
per frame, each over frames that cover several broad-phase windows; `gas` is the periodic equilibrium gas at n = 1e5 (packing 0.05, 0.2, 0.4) and 1e4
(packing 0.2) in simulate mode; `shapes` is issue 25's crowd of 1e4 shapes in detect mode and
the shapes scene in simulate mode with a floor, restitution 0.5 and friction 0.3 at 1e3 and 1e4.
"""
import csv
import json
import os
import subprocess
import sys
import tempfile

# (n, speed in diameters per frame, frames): enough frames for several windows at every speed.
DETECT = [(10000, 0.05, 240), (10000, 0.5, 120), (10000, 5, 60), (100000, 0.05, 240), (100000, 0.5, 60), (100000, 5, 20)]
GAS = [(100000, 0.05, 57, 150), (100000, 0.2, 10, 30), (100000, 0.4, 3, 8), (10000, 0.2, 10, 300)]
SHAPES = [
    ["--bodies", "10000", "--max-speed", "0.5", "--mode", "detect", "--frames", "20"],
    ["--bodies", "1000", "--max-speed", "0.5", "--floor", "--restitution", "0.5", "--friction", "0.3", "--frames", "30"],
    ["--bodies", "10000", "--max-speed", "0.5", "--floor", "--restitution", "0.5", "--friction", "0.3", "--frames", "20"],
]


def cases(kinds):
    if "detect" in kinds:
        for n, speed, frames in DETECT:
            args = ["--bodies", str(n), "--max-speed", str(speed), "--mode", "detect", "--frames", str(frames)]
            yield f"detect n={n} speed={speed}", args, 0
    if "gas" in kinds:
        for n, packing, warm, measured in GAS:
            args = ["--kind", "gas", "--periodic", "xyz", "--bodies", str(n), "--packing", str(packing),
                    "--max-speed", "0.2", "--mode", "simulate", "--frames", str(warm + measured)]
            yield f"gas n={n} packing={packing}", args, warm
    if "shapes" in kinds:
        for extra in SHAPES:
            yield "shapes " + " ".join(extra), ["--kind", "shapes", *extra], 0


def run(binary, args, warm, table):
    command = ["taskset", "-c", "1", binary, "simulate", *args, "--reference", "none", "--threads", "1", "--csv", table]
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(table) as f:
        rows = list(csv.DictReader(f))[warm:]
    ms = sum(float(r["ms"]) for r in rows)
    pairs = sum(int(r["pair_contacts"]) for r in rows)
    contacts = sum(int(r["contacts"]) for r in rows)
    return dict(
        ms_per_frame=ms / len(rows),
        pair_collisions_per_s=pairs / ms * 1e3,
        ms_per_1000_contacts=ms / contacts * 1e3 if contacts else None,
        contacts=contacts,
        frames=len(rows),
    )


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    base, new, out, kinds = sys.argv[1], sys.argv[2], sys.argv[3], set(sys.argv[4:])
    reps = int(os.environ.get("REPS", "3"))
    results = []
    with tempfile.TemporaryDirectory() as scratch:
        table = os.path.join(scratch, "frames.csv")
        only = os.environ.get("ONLY", "")
        for name, args, warm in cases(kinds):
            if only not in name:
                continue
            for rep in range(reps):
                pair = {}
                for build, binary in (("base", base), ("new", new)):
                    row = dict(case=name, rep=rep, build=build, **run(binary, args, warm, table))
                    pair[build] = row
                    results.append(row)
                    print(json.dumps(row), flush=True)
                if pair["base"]["contacts"] != pair["new"]["contacts"] and "detect" in args:
                    sys.exit(f"{name}: the builds report different contacts; no comparison")
    with open(out, "w") as f:
        json.dump(results, f, indent=1)


if __name__ == "__main__":
    main()
