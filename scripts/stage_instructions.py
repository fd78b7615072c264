#!/usr/bin/env python3
"""Each stage of the frame pipeline's instructions, per thread: a detect-mode paper scene run
under callgrind with a dump of each thread's counts at every stage's start and end.

Usage (from a scratch folder; the run writes its profile parts there):
    python3 scripts/stage_instructions.py VADOP SPEED FRAMES THREADS [n=100000]
e.g. `... target/release/vadop 5 4 2` and `... target/release/vadop 5 4 1`, one thread's table
against two threads'.

callgrind dumps the counts of the thread that enters or leaves a function named by
`--dump-before`/`--dump-after`, and only that thread's: the stages' functions
(`ProxyTable::refresh_all`, `Grid::bin`, `find_pairs_screened`, `EventQueue::set_bulk`,
`PassedContacts::work_out_ahead` and `resolve`, `Workers::extend_ranges` for the foresight's wall
contacts and the bodies' own passes, which are inlined into `Pipeline::step`, and the foresight's
`foresee_bounces`, marked at its start only: its stage runs on to the binning, as its two passes'
did before it) mark the stages on the thread that
runs the pipeline, and rayon's `Job::execute` marks each job the other thread steals. The parts
are numbered in the order they were dumped, whichever thread's: a part belongs to the stage whose
end is the next stage mark. Per stage: the instructions of the thread that runs the pipeline
(its own share, its waiting and what it stole), the other thread's jobs, and the other thread's
instructions between jobs (its idle wait; rayon puts a thread to sleep after a few rounds).
Runs with `--fair-sched=yes`, so two threads take turns on valgrind's one core; the split between
them still follows valgrind's scheduling, not two cores' (a thread woken at a stage's start waits
for its turn), so read a stage's sum against one thread's count (the extra work of sharing it out)
more than its split. "Outside the stages": the scene's set-up, the CLI's own thread, the steps'
ends. The stages are told apart by the order of the marks, as `Pipeline::step`
calls them: a change of that order needs a change of `NAMES` below.
"""
import collections
import glob
import os
import re
import subprocess
import sys

MARKED = ["*ProxyTable::refresh_all", "*Workers::extend_ranges*", "*Grid::bin", "*find_pairs_screened",
          "*EventQueue::set_bulk", "*PassedContacts::work_out_ahead", "*PassedContacts::resolve",
          "*Pipeline<B>::step", "*Job>::execute"]
# Marked at their start only: the stage runs on from there to the next mark.
STARTS = ["*foreseen::foresee_bounces"]
SHORT = [("Job>::execute", "execute"), ("refresh_all", "refresh"), ("extend_ranges", "ext"), ("Grid::bin", "bin"),
         ("find_pairs_screened", "pairs"), ("set_bulk", "sort"), ("work_out_ahead", "ahead"),
         ("resolve", "resolve"), ("Pipeline<B>::step", "step"), ("foresee_bounces", "foresee")]
# A stage by the marks that begin and end it on the thread running the pipeline (callgrind misses
# the entry or the exit of some of these functions: the marks it gives are the ones listed).
NAMES = {
    ("before refresh", "after refresh"): "refresh",
    ("before ext", "before bin"): "foreseen paths",
    ("before ext", "before foresee"): "wall contacts",
    ("before foresee", "before bin"): "foreseen bounces and paths",
    ("before bin", "after bin"): "binning",
    ("before pairs", "before ext"): "pair sweep",
    ("before ext", "after pairs"): "pair sweep",
    ("before ext", "before sort"): "own events",
    ("before sort", "after sort"): "sort",
    ("before ext", "after ahead"): "work out ahead",
    ("after sort", "before ext"): "work out ahead",
    ("after sort", "after ahead"): "work out ahead",
    ("after step", "before ext"): "work out ahead",
    ("after step", "after ahead"): "work out ahead",
    ("after ahead", "after resolve"): "serial loop and resolve",
    ("after ahead", "before refresh"): "serial loop and the window rule",
}
STAGES = ["refresh", "wall contacts", "foreseen bounces", "foreseen paths", "foreseen bounces and paths", "binning", "pair sweep",
          "own events", "sort", "work out ahead", "serial loop and resolve", "serial loop and the window rule"]


def run(vadop, speed, frames, threads, bodies):
    marks = [f"--dump-{when}={name}" for name in MARKED for when in ("before", "after")]
    marks += [f"--dump-before={name}" for name in STARTS]
    command = ["valgrind", "--tool=callgrind", "--separate-threads=yes", "--fair-sched=yes",
               "--callgrind-out-file=stages.cg", *marks, vadop, "simulate", "--bodies", str(bodies),
               "--max-speed", str(speed), "--mode", "detect", "--frames", str(frames), "--reference", "none",
               "--threads", str(threads)]
    for old in glob.glob("stages.cg*"):
        os.remove(old)
    subprocess.run(command, check=True, capture_output=True)


def parts():
    """(order, thread, mark, instructions) of every dumped part, the threads' last counts last."""
    found = []
    for path in glob.glob("stages.cg*"):
        numbered, last = re.search(r"\.(\d+)-(\d+)$", path), re.search(r"stages\.cg-(\d+)$", path)
        if not (numbered or last):
            continue
        mark, count = "end", None
        with open(path) as f:
            for line in f:
                if line.startswith("desc: Trigger:") and numbered:
                    text = line.split("Trigger: ", 1)[1]
                    when = "before" if "dump-before" in text else "after"
                    mark = next(f"{when} {short}" for key, short in SHORT if key in text)
                elif line.startswith("summary:"):
                    count = int(line.split()[1])
                    break
        order = int(numbered.group(1)) if numbered else 1 << 60
        found.append((order, (numbered or last).group(2 if numbered else 1), mark, count))
    return sorted(found)


def table(frames):
    found = parts()
    # Each stage mark names the stage that ends there (the foresight's passes by their order).
    labels, previous, passes, in_pairs = {}, "start", 0, False
    for k, (_, thread, mark, _) in enumerate(found):
        if "execute" in mark or mark == "end":
            continue
        if mark == "after refresh":
            passes = 0
        in_pairs = (in_pairs or mark == "before pairs") and mark != "after pairs"
        if (previous, mark) == ("before ext", "before ext") and not in_pairs:
            passes += 1
            name = {1: "wall contacts", 2: "foreseen bounces"}.get(passes, "other")
        else:
            name = NAMES.get((previous, mark), "other")
        labels[k] = (name, thread)
        previous = mark
    counts = collections.defaultdict(collections.Counter)
    stage = ("other", None)
    for k in range(len(found) - 1, -1, -1):
        stage = labels.get(k, stage)
        _, thread, mark, count = found[k]
        role = "pipeline" if thread == stage[1] else ("idle" if mark == "before execute" else "other")
        counts[stage[0]][role] += count
    print(f"{'stage':32} {'pipeline':>9} {'other':>9} {'idle':>9}   M a frame")
    for name in STAGES + ["other"]:
        c = counts[name]
        label = "outside the stages" if name == "other" else name
        print(f"{label:32} " + " ".join(f"{c[role] / frames / 1e6:9.2f}" for role in ("pipeline", "other", "idle")))


def main():
    vadop, speed, frames, threads = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4]
    bodies = int(sys.argv[5]) if len(sys.argv) > 5 else 100000
    run(os.path.abspath(vadop), speed, frames, threads, bodies)
    table(frames)


if __name__ == "__main__":
    main()
