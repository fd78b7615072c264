"""Spinning boxes: bullets shot through a tumbling crowd of boxes, each contact's start and end.

In detect mode bodies pass through each other, so a bullet (a small fast capsule) crosses the
whole crowd, and with ``contact_ends=True`` the world reports when each of its contacts starts
and when it ends: how long the bullet spent inside each box. The boxes tumble (a brick spinning
about no principal axis) and their exact rotation is followed between frames, so a contact
starts at the instant a swinging corner meets the bullet, however far both move in a frame. The
run is also written as a viewer page.

    python examples/python/spinning_boxes.py [--boxes 300] [--bullets 3] [--frames 20] [--out PAGE.html]
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np
import numpy.typing as npt

import vadop
from vadop.viewer import record, write_html

DT = 1 / 30


def crowd(boxes: int, bullets: int, frames: int) -> tuple[vadop.World, set[int]]:
    """The world, and the ids of its bullets: a lattice of spinning bricks, bullets fired along
    +x from the box's low x side, fast enough to cross it in about half the frames (and come
    back off the far wall)."""
    per_side = int(np.ceil(boxes ** (1 / 3)))
    spacing = 2.5
    side = spacing * (per_side + 1)
    world = vadop.World(box=side, mode="detect", contact_ends=True)
    brick = world.add_shape("cuboid", half_extents=[0.9, 0.5, 0.3])
    slug = world.add_shape("capsule", half_height=0.2, radius=0.06)
    rng = np.random.default_rng(4)
    cells = np.stack(np.meshgrid(*[np.arange(per_side, dtype=np.float64)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)
    orientations = rng.normal(size=(boxes, 4))
    world.add_bodies(brick, spacing * (cells[:boxes] + 1), rng.normal(scale=0.2, size=(boxes, 3)), orientations,
                     rng.normal(scale=4.0, size=(boxes, 3)))
    # Each along a row of the lattice, a little off its centre line.
    rows = spacing * (rng.integers(per_side, size=(bullets, 2)) + 1.0) + rng.uniform(-0.3, 0.3, (bullets, 2))
    starts: npt.NDArray[np.float64] = np.column_stack([np.full(bullets, 0.3), rows])
    speed = side / (frames / 2 * DT)
    # A capsule lies along its own y axis: turned a quarter about z, it flies point first along x.
    along_x = [[0.0, 0.0, -np.sqrt(0.5), np.sqrt(0.5)]] * bullets
    fired = world.add_bodies(slug, starts, np.tile([speed, 0.0, 0.0], (bullets, 1)), along_x)
    return world, set(fired.tolist())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--boxes", type=int, default=300)
    parser.add_argument("--bullets", type=int, default=3)
    parser.add_argument("--frames", type=int, default=20)
    # Into the system's temporary directory unless told: never into the working tree.
    default = Path(tempfile.gettempdir()) / "vadop-examples" / "spinning_boxes.html"
    parser.add_argument("--out", type=Path, default=default, help=f"viewer page to write (default {default})")
    args = parser.parse_args()

    world, bullets = crowd(args.boxes, args.bullets, args.frames)
    # Per (bullet, box): when the contact started, and the contact spans seen so far.
    inside: dict[tuple[int, int], float] = {}
    spans: dict[int, list[tuple[int, float, float]]] = {bullet: [] for bullet in bullets}
    for _ in range(args.frames):
        starts = world.step(DT)
        ends = world.contact_ends()
        # A pair's end may come in the same frame as its start: starts first.
        for contacts, starting in ((starts, True), (ends, False)):
            for t, i, j in zip(contacts.time, contacts.i.tolist(), contacts.j.tolist()):
                pair = (i, j) if i in bullets else (j, i)
                if pair[0] not in bullets or pair[1] in bullets or j < 0:
                    continue  # walls, boxes meeting boxes, bullets meeting bullets
                if starting:
                    inside[pair] = float(t)
                else:
                    spans[pair[0]].append((pair[1], inside.pop(pair), float(t)))
    for bullet, seen in spans.items():
        print(f"bullet {bullet}: {len(seen)} contacts with boxes")
        for box, start, end in seen[:5]:
            print(f"  box {box}: contact starts at {start:.5f} s, ends at {end:.5f} s ({(end - start) * 1e3:.2f} ms inside)")
    print(f"{len(inside)} contacts still going on at {world.time:.3f} s")
    # record() steps a world of its own: the same one again, from the start.
    args.out.parent.mkdir(parents=True, exist_ok=True)
    page = write_html(record(crowd(args.boxes, args.bullets, args.frames)[0], frames=args.frames, dt=DT), args.out)
    print(f"wrote {page}: open it in a browser")


if __name__ == "__main__":
    main()
