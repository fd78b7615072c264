#!/usr/bin/env python3
"""vadop's periodic hard-sphere gas timed beside a dedicated event-driven MD code, in one command.

Usage: python3 scripts/beside_edmd.py EDMD_SOURCE SCRATCH VADOP OUT.jsonl [REPS=2]

EDMD_SOURCE is a checkout of Smallenburg's EDMD (github.com/FSmallenburg/EDMD, MIT licence; the
figures in BENCHMARKS.md are of commit 2d0c862). Its code never enters this repository: the
script copies the Cell and Single variants into SCRATCH, patches each one's `main` to take the
particle count, packing and times from the environment and to time its event loop after a
warm-up (the only change: no physics, no scheduling parameter touched), and builds them with the
flags of their Makefiles. Then, for packings 0.05, 0.2 and 0.4 at N = 97,556 (EDMD's FCC start
needs 4 x k^3 particles), each repetition runs vadop's equilibrium gas (`vadop simulate --kind gas
--periodic xyz --max-speed 0.2 --mode simulate --threads 1`, the frames `ab_runs.py`'s gas case
runs, its warm-up frames dropped) and the two EDMD variants, one after the other, each pinned to
core 1 with taskset. Pair collisions per second of each run's timed part, one JSON line per run
to OUT.jsonl and the screen; read the ratios within a repetition, the machine drifts between them.
"""
import csv
import json
import os
import shutil
import subprocess
import sys
import tempfile

N = 97556
# Packing; vadop's warm-up and measured frames (as ab_runs.py); EDMD's warm-up and end time (its
# time unit: diameter 1, mass 1, kT = 1).
CASES = [(0.05, 57, 150, 3.0, 11.0), (0.2, 10, 30, 1.0, 4.0), (0.4, 3, 8, 0.5, 1.5)]
VARIANTS = {"Cell": "mdCell", "Single": "mdSingle"}

TIMED_MAIN = r'''int main()
{
    /* Patched by vadop's scripts/beside_edmd.py: size, packing and times from the environment,
       the loop after the warm-up timed. */
    N = atoi(getenv("EDMD_N")); packfrac = atof(getenv("EDMD_PACK")); maxtime = atof(getenv("EDMD_T"));
    double warm = atof(getenv("EDMD_WARM"));
    init();
    while (simtime <= warm) step();
    unsigned int c0 = colcounter; struct timespec t0, t1; clock_gettime(CLOCK_MONOTONIC, &t0);
    while (simtime <= maxtime) step();
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double secs = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    printf("TIMED collisions %u seconds %.6f\n", colcounter - c0, secs);
    simtime = maxtime;
    printstuff();
'''


def build(source, scratch):
    """Copies, patches and builds each variant; returns the binaries by variant."""
    binaries = {}
    for variant, stem in VARIANTS.items():
        folder = os.path.join(scratch, variant)
        shutil.copytree(os.path.join(source, variant), folder, dirs_exist_ok=True)
        path = os.path.join(folder, stem + ".c")
        code = open(path).read()
        start = code.index("int main()\n{\n    init();")
        end = code.index("    outputsnapshot();", start) + len("    outputsnapshot();")
        code = "#include <time.h>\n#include <stdlib.h>\n" + code[:start] + TIMED_MAIN + code[end:]
        code = code.replace("int initialconfig = 0;", "int initialconfig = 1;", 1)  # the FCC start
        open(path, "w").write(code)
        binary = os.path.join(folder, "md")
        subprocess.run(["gcc", "-Wall", "-Ofast", "-funroll-loops", "-march=native", path, "-o", binary, "-lm"],
                       check=True, capture_output=True)
        binaries[variant] = binary
    return binaries


def run_vadop(vadop, packing, warm, measured):
    with tempfile.TemporaryDirectory() as scratch:
        table = os.path.join(scratch, "frames.csv")
        subprocess.run(["taskset", "-c", "1", vadop, "simulate", "--kind", "gas", "--periodic", "xyz",
                        "--bodies", str(N), "--packing", str(packing), "--max-speed", "0.2", "--mode", "simulate",
                        "--frames", str(warm + measured), "--reference", "none", "--threads", "1", "--csv", table],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rows = list(csv.DictReader(open(table)))[warm:]
    seconds = sum(float(r["ms"]) for r in rows) / 1e3
    return sum(int(r["pair_contacts"]) for r in rows), seconds


def run_edmd(binary, packing, warm, end):
    env = dict(os.environ, EDMD_N=str(N), EDMD_PACK=str(packing), EDMD_T=str(end), EDMD_WARM=str(warm))
    with tempfile.TemporaryDirectory() as scratch:  # it writes no file, but runs where it may
        printed = subprocess.run(["taskset", "-c", "1", binary], env=env, cwd=scratch, check=True,
                                 capture_output=True, text=True).stdout
    words = next(line for line in printed.splitlines() if line.startswith("TIMED")).split()
    return int(words[2]), float(words[4])


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    source, scratch, vadop, out = sys.argv[1:5]
    reps = int(sys.argv[5]) if len(sys.argv) > 5 else 2
    binaries = build(source, scratch)
    with open(out, "a") as log:
        for packing, warm, measured, edmd_warm, edmd_end in CASES:
            for rep in range(reps):
                runs = [("vadop", lambda: run_vadop(vadop, packing, warm, measured))]
                runs += [(f"EDMD {v}", lambda b=b: run_edmd(b, packing, edmd_warm, edmd_end)) for v, b in binaries.items()]
                for code, run in runs:
                    collisions, seconds = run()
                    row = dict(packing=packing, rep=rep, code=code, collisions=collisions,
                               per_second=round(collisions / seconds), load=os.getloadavg()[0])
                    print(json.dumps(row), flush=True)
                    log.write(json.dumps(row) + "\n")


if __name__ == "__main__":
    main()
