"""Bullets through a crowd: a few very fast small spheres fired through a slow crowd.

A bullet crosses several sphere diameters per frame, so a check at frame instants would see it
on either side of a body and never touching it; the continuous step reports every hit, with its
exact time and point.

    python examples/python/bullets_through_crowd.py [--crowd 2000] [--bullets 5]
"""

import argparse

import numpy as np

import vadop


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--crowd", type=int, default=2000)
    parser.add_argument("--bullets", type=int, default=5)
    args = parser.parse_args()

    # The crowd: the paper's scene, slow; in detect mode so bullets fly straight through and we
    # can count every body each one passes.
    world = vadop.scene(args.crowd, 0.1, 0.05, mode="detect")
    side = float(world.box[1, 0])
    rng = np.random.default_rng(3)
    starts = np.column_stack([np.full(args.bullets, 0.2), rng.uniform(1, side - 1, (args.bullets, 2))])
    # 20 diameters per frame at 30 frames per second, along +x.
    velocities = np.tile([20.0 * 30, 0.0, 0.0], (args.bullets, 1))
    bullets = world.add(starts, velocities, np.full(args.bullets, 0.1), np.full(args.bullets, 0.01))

    hits: dict[int, int] = {int(b): 0 for b in bullets}
    first: dict[int, tuple[float, int]] = {}
    for _ in range(3):
        contacts = world.step(1 / 30)
        pair = contacts.j >= 0
        for t, i, j in zip(contacts.time[pair], contacts.i[pair], contacts.j[pair]):
            for bullet, other in ((int(i), int(j)), (int(j), int(i))):
                if bullet in hits and other not in hits:
                    hits[bullet] += 1
                    first.setdefault(bullet, (float(t), other))
    for bullet, count in hits.items():
        when = f", first at t = {first[bullet][0]:.5f} s (body {first[bullet][1]})" if bullet in first else ""
        print(f"bullet {bullet}: touched {count} bodies{when}")


if __name__ == "__main__":
    main()
