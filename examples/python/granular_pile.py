"""Granular pile: spheres dropped into a box under gravity come to rest on the floor and on each other.

Simulate mode with gravity 9.81 (one-unit balls under the Earth's pull) and restitution 0.5: every
bounce is found at its exact instant, ever lower, until a bounce would rise less than 1e-4 of the
radius; then the sphere lies still instead (``World.rest``), on the floor or on spheres lying still,
so the pile settles and the frames fall quiet. Prints, each second, the contacts, the spheres
lying still, and the energy (kinetic plus potential), which only falls (but for the rest rule's
hops, far below what it shows).

    python examples/python/granular_pile.py [--bodies 400] [--frames 240] [--out PAGE.html]
"""

import argparse
import tempfile
from pathlib import Path

import numpy as np

import vadop
from vadop.viewer import record, write_html

DT = 1 / 30
G = 9.81


def pile_world(bodies: int) -> vadop.World:
    """Spheres of radii 0.3 to 0.5 on a jittered grid filling a box, at rest, under gravity."""
    rng = np.random.default_rng(5)
    per_axis = int(np.ceil(bodies ** (1 / 3)))
    side = 1.2 * per_axis
    cells = np.stack(np.meshgrid(*[np.arange(per_axis)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:bodies]
    positions = (cells + 0.5) * (side / per_axis) + rng.uniform(-0.05, 0.05, size=(bodies, 3))
    radii = rng.uniform(0.3, 0.5, bodies)
    return vadop.World(positions, np.zeros((bodies, 3)), radii, radii**3, box=side, gravity=(0, 0, -G), restitution=0.5)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--bodies", type=int, default=400)
    parser.add_argument("--frames", type=int, default=240)
    parser.add_argument("--out", type=Path, help="also write a viewer page of the run here")
    args = parser.parse_args()

    world = pile_world(args.bodies)
    energy = world.kinetic_energy() + world.potential_energy()
    contacts = rests = 0
    for frame in range(1, args.frames + 1):
        contacts += len(world.step(DT))
        rests += int(world.stats()["rest_contacts"])
        now = world.kinetic_energy() + world.potential_energy()
        # Restitution below 1 only takes energy away (but for rounding); a hop adds a few
        # millionths at most.
        hops = 1e-4 * world.stats()["rest_contacts"]
        assert now <= energy + hops + 1e-12 * abs(energy), f"frame {frame}: energy {energy} -> {now}"
        energy = now
        if frame % 30 == 0:
            still = world.rest.count("still")
            print(f"{frame * DT:4.0f} s: {contacts:6d} contacts ({rests:5d} by the rest rule), "
                  f"{still:4d} of {args.bodies} lying still, energy {energy:9.2f}")
            contacts = rests = 0
    heights = world.positions[:, 2] - world.radii
    print(f"{world.rest.count('still')} of {args.bodies} spheres lie still; lowest bottom at z = {heights.min():.3g}")
    if args.out is not None:
        # record() steps a world of its own: the same one again, from the start.
        page = write_html(record(pile_world(args.bodies), frames=args.frames, dt=DT), args.out)
        print(f"wrote {page}: open it in a browser")


if __name__ == "__main__":
    main()
