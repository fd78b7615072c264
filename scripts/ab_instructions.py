#!/usr/bin/env python3
"""Before and after in instructions: two builds run under callgrind on the same commands.

Usage: python3 scripts/ab_instructions.py BASE_DIR NEW_DIR OUT.md [detect] [gas] [shapes] [peers]
                                          [spheres] [times-may-move]

BASE_DIR and NEW_DIR are the `target/release` folders of two builds (e.g. one built at an older
commit in a git worktree, and this one's). Each case runs once per build under `valgrind
--tool=callgrind`, and the count kept is the instructions inside the frame loop, inclusive:
`vadop::world::World::step` for a `vadop simulate` case, `vadop::pipeline::Pipeline<B>::step` for
a case of the peers' shapes or spheres scene (`vadop-bench --child --job peers-time`, pinned to
core 1 with taskset so it runs one worker, as in the benchmark; its contacts file holds the pairs
alone). Instruction counts do not depend on the
machine's load, so this is the comparison to make on a shared or busy host, where times are
drafts; it says nothing of memory stalls, which times do. Both builds' contacts files are
compared byte for byte in every case but the gas's (times and points included, so a change that
moves contact times inside the tolerance stops it too), and the script stops when they differ;
with `times-may-move`, for a change that moves contact times within the tolerance on purpose,
the CLI's files need only hold the same pairs in the same order, and the peers' child's the same
pairs in each frame (two contacts of one frame a hair apart in time may swap).
OUT.md gets a markdown table: case, base, new, new ÷ base.

Cases: `detect` is the paper scene in detect mode at n = 1e4 (5 and 0.5 diameters per frame)
and 1e5 (0.05 and 5); `gas` the periodic equilibrium gas at n = 2e4, packing 0.2, 0.05, 0.35, 0.4 and
0.45 (the last three where the serial event loop keeps neighbour lists);
`shapes` the shapes crowd of issue 25 in detect mode; `peers` the peers' shapes scene at n = 1e4
(0.05, 0.5 and 5 d/f) and 1e5 (0.05); `spheres` the peers' spheres scene (issue 28's table,
the default method) at n = 1e4 (5 and 0.5 d/f) and 1e5 (5 d/f). valgrind runs a program about 50
times slower: the whole set takes about ten minutes.
"""
import filecmp
import os
import subprocess
import sys
import tempfile

DETECT = [(10000, 5, 30), (10000, 0.5, 60), (100000, 0.05, 20), (100000, 5, 6)]
GAS = [(20000, 0.2, 20), (20000, 0.05, 40), (20000, 0.35, 12), (20000, 0.4, 10), (20000, 0.45, 8)]
PEERS = [(10000, 0.05, 30), (10000, 0.5, 10), (10000, 5, 3), (100000, 0.05, 10)]
SPHERES = [(10000, 5, 20), (10000, 0.5, 30), (100000, 5, 4)]


def cases(kinds):
    """(label, program, arguments, whether the two builds' contacts are compared)."""
    if "detect" in kinds:
        for n, speed, frames in DETECT:
            args = ["--bodies", str(n), "--max-speed", str(speed), "--mode", "detect", "--frames", str(frames)]
            yield f"`vadop simulate {' '.join(args)}`", "vadop", args, True
    if "gas" in kinds:
        for n, packing, frames in GAS:
            args = ["--kind", "gas", "--periodic", "xyz", "--bodies", str(n), "--packing", str(packing),
                    "--max-speed", "0.2", "--mode", "simulate", "--frames", str(frames)]
            yield f"`vadop simulate {' '.join(args)}`", "vadop", args, False
    if "shapes" in kinds:
        args = ["--kind", "shapes", "--bodies", "10000", "--max-speed", "0.5", "--mode", "detect", "--frames", "5"]
        yield f"`vadop simulate {' '.join(args)}`", "vadop", args, True
    for kind, scene, runs in (("peers", "shapes", PEERS), ("spheres", "spheres", SPHERES)):
        if kind in kinds:
            for n, speed, frames in runs:
                args = ["--child", "--job", "peers-time", "--scene", scene, "--bodies", str(n), "--speed", str(speed),
                        "--frames", str(frames), "--method", "auto"]
                yield f"peers' {scene} scene, n = {n}, {speed} d/f, {frames} frames", "vadop-bench", args, True


def instructions(folder, program, args, checked, scratch, tag):
    """The frame loop's inclusive instruction count, and the contacts file written (or None)."""
    profile = os.path.join(scratch, f"{tag}.callgrind")
    contacts = os.path.join(scratch, f"{tag}.contacts" + (".csv" if program == "vadop" else ""))
    binary = os.path.join(folder, program)
    valgrind = ["valgrind", "--tool=callgrind", f"--callgrind-out-file={profile}"]
    if program == "vadop":
        command = valgrind + [binary, "simulate", *args, "--reference", "none", "--threads", "1"]
        command += ["--contacts", contacts] if checked else []
        function = "vadop::world::World::step ["
    else:
        # Pinned, so the child's workers are one, as in the benchmark.
        command = ["taskset", "-c", "1", *valgrind, binary, *args, "--out", contacts]
        function = "vadop::pipeline::Pipeline<B>::step ["
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    # Annotated from the scratch folder: from the build's source folder, callgrind_annotate
    # shortens the paths under it and splits a function's cost between two names.
    annotated = subprocess.run(["callgrind_annotate", "--inclusive=yes", profile], check=True,
                               capture_output=True, text=True, cwd=scratch).stdout
    for line in annotated.splitlines():
        if function in line and ":" in line:
            return int(line.split()[0].replace(",", "")), contacts if checked else None
    sys.exit(f"{function} not found in the profile of {' '.join(command)}")


def same_contacts(base, new, times_may_move):
    """Whether two contacts files agree: byte for byte, or with `times_may_move` the same pairs
    (frame, bodies, what they touched) in the same order, times and points free to move (the
    peers' child writes the pairs alone, frame and bodies, in time order: there the same pairs
    in each frame)."""
    if filecmp.cmp(base, new, shallow=False):
        return True
    if not times_may_move:
        return False
    if not base.endswith(".csv"):
        return sorted_records(base) == sorted_records(new)
    with open(base) as a, open(new) as b:
        rows = [[line.split(",")[:1] + line.split(",")[2:5] for line in f] for f in (a, b)]
    return rows[0] == rows[1]


def sorted_records(path):
    """The peers' child's contacts file as its sorted records (frame and the two bodies, three
    little-endian u32 each): the same in each frame whatever their order within it."""
    with open(path, "rb") as f:
        data = f.read()
    return sorted(data[k:k + 12] for k in range(0, len(data), 12))


def main():
    if len(sys.argv) < 5:
        sys.exit(__doc__)
    base, new, out, kinds = sys.argv[1], sys.argv[2], sys.argv[3], set(sys.argv[4:])
    times_may_move = "times-may-move" in kinds
    rows = ["| case | base | new | new ÷ base |", "|---|---:|---:|---:|"]
    with tempfile.TemporaryDirectory() as scratch:
        for k, (label, program, args, checked) in enumerate(cases(kinds)):
            counts = []
            files = []
            for build, folder in (("base", base), ("new", new)):
                count, contacts = instructions(folder, program, args, checked, scratch, f"{k}-{build}")
                counts.append(count)
                files.append(contacts)
            if checked and not same_contacts(files[0], files[1], times_may_move):
                sys.exit(f"{label}: the builds report different contacts; no comparison")
            row = f"| {label} | {counts[0] / 1e6:,.1f} M | {counts[1] / 1e6:,.1f} M | {counts[1] / counts[0]:.3f} |"
            rows.append(row)
            print(row, flush=True)
    with open(out, "w") as f:
        f.write("\n".join(rows) + "\n")


if __name__ == "__main__":
    main()
