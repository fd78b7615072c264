"""Debris on a mesh: bodies of every shape thrown down onto a static triangle-mesh terrain.

Simulate mode with restitution 0.6 and friction 0.4: every bounce off the terrain is found at its
exact instant, however fast the debris falls, and loses energy to restitution and friction,
while friction turns sliding into spin. The engine applies no gravity (bodies move in straight
lines between contacts), so the debris is thrown down instead of dropped. Prints the bounces of
each frame and the kinetic energy, which only ever falls.

    python examples/python/debris_on_mesh.py [--debris 60] [--frames 60] [--out PAGE.html]
"""

import argparse
import tempfile
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

import vadop
from vadop.viewer import record, write_html

DT = 1 / 30
SIDE = 20.0
DEBRIS: list[dict[str, Any]] = [
    dict(kind="sphere", radius=0.4),
    dict(kind="cuboid", half_extents=[0.5, 0.3, 0.2]),
    dict(kind="capsule", half_height=0.35, radius=0.2),
    dict(kind="cylinder", half_height=0.3, radius=0.35),
    dict(kind="cone", half_height=0.4, radius=0.35),
    # A rock: the hull of a few points about its centre.
    dict(kind="convex_hull", points=np.random.default_rng(1).normal(scale=0.35, size=(12, 3))),
]


def terrain(cells: int) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.int64]]:
    """Rolling hills about z = 2 a little wider than the box: a grid of cells x cells squares,
    two triangles each."""
    ticks = np.linspace(-2.0, SIDE + 2.0, cells + 1)
    x, y = np.meshgrid(ticks, ticks, indexing="ij")
    z = 2.0 + 0.8 * np.sin(x / 3) * np.cos(y / 4)
    vertices = np.column_stack([x.ravel(), y.ravel(), z.ravel()])
    corner = (np.arange(cells)[:, None] * (cells + 1) + np.arange(cells)[None, :]).ravel()
    up = cells + 1  # the next row of vertices
    triangles = np.concatenate([np.column_stack([corner, corner + up, corner + 1]),
                                np.column_stack([corner + 1, corner + up, corner + up + 1])])
    return vertices, triangles.astype(np.int64)


def debris_world(debris: int) -> tuple[vadop.World, int]:
    """The world and its terrain's id: debris on a loose lattice high above the terrain, thrown
    down and spinning."""
    world = vadop.World(box=SIDE, mode="simulate", restitution=0.6, friction=0.4)
    vertices, triangles = terrain(16)
    ground = world.add_static(world.add_shape("trimesh", vertices=vertices, triangles=triangles), [0.0, 0, 0])
    kinds = np.array([world.add_shape(**shape) for shape in DEBRIS])
    rng = np.random.default_rng(2)
    cells = np.stack(np.meshgrid(np.arange(5), np.arange(5), np.arange(debris // 25 + 1), indexing="ij"),
                     axis=-1).reshape(-1, 3)[:debris]
    positions = np.column_stack([3.0 + 3.4 * cells[:, :2], 9.0 + 2.5 * cells[:, 2]])
    velocities = np.column_stack([rng.normal(size=(debris, 2)), np.full(debris, -12.0)])
    world.add_bodies(kinds[np.arange(debris) % len(kinds)], positions, velocities, rng.normal(size=(debris, 4)),
                     rng.normal(scale=3.0, size=(debris, 3)), rng.uniform(0.5, 2.0, debris))
    return world, ground


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--debris", type=int, default=60)
    parser.add_argument("--frames", type=int, default=60)
    # Into the system's temporary directory unless told: never into the working tree.
    default = Path(tempfile.gettempdir()) / "vadop-examples" / "debris_on_mesh.html"
    parser.add_argument("--out", type=Path, default=default, help=f"viewer page to write (default {default})")
    args = parser.parse_args()

    world, ground = debris_world(args.debris)
    start = energy = world.kinetic_energy()
    bounces = 0
    for frame in range(args.frames):
        contacts = world.step(DT)
        on_ground = (contacts.i == ground) | (contacts.j == ground)
        between_debris = (contacts.j >= 0) & ~on_ground
        bounces += int(on_ground.sum())
        now = world.kinetic_energy()
        # Restitution below 1 and friction only ever take energy away.
        assert now <= energy * (1 + 1e-9), f"kinetic energy rose from {energy} to {now}"
        energy = now
        if on_ground.any():
            hardest = float(contacts.impulse[on_ground].max())
            print(f"frame {frame:3d}: {int(on_ground.sum()):3d} bounce(s) on the terrain (hardest impulse {hardest:.2f}), "
                  f"{int(between_debris.sum()):3d} between debris, kinetic energy {energy:.1f}")
    print(f"{bounces} bounces on the terrain; kinetic energy {start:.1f} -> {energy:.1f} "
          f"({100 * (1 - energy / start):.0f} % lost to restitution and friction)")
    lowest = float(world.positions[~world.static, 2].min())
    print(f"lowest debris at z = {lowest:.2f} (the terrain lies between z = 1.2 and 2.8)")
    # record() steps a world of its own: the same one again, from the start.
    args.out.parent.mkdir(parents=True, exist_ok=True)
    page = write_html(record(debris_world(args.debris)[0], frames=args.frames, dt=DT), args.out)
    print(f"wrote {page}: open it in a browser")


if __name__ == "__main__":
    main()
