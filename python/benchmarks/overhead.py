"""Python overhead: stepping the paper's scene from Python against the Rust CLI on the same scene.

Both sides step the same generated scene (same seed, bodies, packing fraction, speeds) for the
same frames and time each step's wall clock: the CLI around `World::step`, Python around
`World.step` (which also copies the contacts into numpy arrays). Runs alternate, so a busy
machine slows both alike; the medians of the per-frame times are compared. The result goes into
BENCHMARKS.md between the python-overhead markers.

    cargo build --release -p vadop-cli
    .venv/bin/python python/benchmarks/overhead.py [--bodies 100000] [--frames 30] [--rounds 3]
"""

from __future__ import annotations

import argparse
import csv
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import vadop

ROOT = Path(__file__).resolve().parents[2]
BEGIN, END = "<!-- python-overhead:begin -->", "<!-- python-overhead:end -->"


def cli_frames(args: argparse.Namespace) -> list[float]:
    """Per-frame wall-clock milliseconds of one CLI run."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "frames.csv"
        subprocess.run([str(ROOT / "target" / "release" / "vadop"), "simulate", "--bodies", str(args.bodies),
                        "--packing", str(args.packing_fraction), "--max-speed", str(args.max_speed),
                        "--frames", str(args.frames), "--csv", str(out), "--quiet"], check=True)
        return [float(row["wall_ms"]) for row in csv.DictReader(out.open())]


def python_frames(args: argparse.Namespace) -> tuple[list[float], list[float]]:
    """Per-frame wall-clock and engine (c_total) milliseconds of one Python run."""
    world = vadop.scene(args.bodies, args.packing_fraction, args.max_speed)
    wall, engine = [], []
    for _ in range(args.frames):
        start = time.perf_counter()
        world.step(1 / 30)
        wall.append((time.perf_counter() - start) * 1e3)
        engine.append(world.stats()["total_seconds"] * 1e3)
    return wall, engine


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bodies", type=int, default=100_000)
    parser.add_argument("--packing-fraction", type=float, default=0.05)
    parser.add_argument("--max-speed", type=float, default=0.5)
    parser.add_argument("--frames", type=int, default=30)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-write", action="store_true", help="print only; leave BENCHMARKS.md alone")
    args = parser.parse_args()

    cli: list[float] = []
    py: list[float] = []
    engine: list[float] = []
    for _ in range(args.rounds):
        cli += cli_frames(args)
        wall, c_total = python_frames(args)
        py += wall
        engine += c_total
    cli_ms, py_ms, engine_ms = statistics.median(cli), statistics.median(py), statistics.median(engine)
    overhead = py_ms / cli_ms - 1
    binding_ms = statistics.median(w - e for w, e in zip(py, engine))
    section = "\n".join([
        BEGIN,
        f"Stepping {args.bodies} bodies (packing fraction {args.packing_fraction}, speeds up to {args.max_speed} "
        f"diameters per frame), {args.rounds} alternating rounds of {args.frames} frames, median wall-clock per frame:",
        "",
        "| | ms per frame |",
        "|---|---|",
        f"| Rust CLI (`vadop simulate`) | {cli_ms:.2f} |",
        f"| Python (`World.step`, contacts copied to numpy) | {py_ms:.2f} |",
        f"| of which engine time c_total (Python run) | {engine_ms:.2f} |",
        "",
        f"Python overhead: **{overhead * 100:+.1f}%** against the CLI (target: within 10%); the binding's own "
        f"share, wall clock minus engine time of the Python steps, is {binding_ms:.2f} ms per frame "
        f"({binding_ms / engine_ms * 100:.2f}%): the rest of the difference is timing noise between runs.",
        END,
    ])
    print(section)
    if not args.no_write:
        path = ROOT / "BENCHMARKS.md"
        text = path.read_text()
        if BEGIN in text:
            head, rest = text.split(BEGIN, 1)
            text = head + section + rest.split(END, 1)[1]
        else:
            text = text.rstrip("\n") + "\n\n## Python overhead (issue #6)\n\nReproduce with:\n\n" \
                "    cargo build --release -p vadop-cli\n    .venv/bin/python python/benchmarks/overhead.py\n\n" + section + "\n"
        path.write_text(text)


if __name__ == "__main__":
    main()
