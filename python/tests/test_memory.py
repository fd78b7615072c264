"""No memory growth over many steps, in Rust allocations (resident size) or Python objects."""

import gc
import os
import weakref

import numpy as np
import pytest

import vadop


def resident_bytes():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs Linux /proc")
def test_no_growth_over_many_steps():
    world = vadop.scene(500, 0.05, 0.5)

    def run(frames):
        for _ in range(frames):
            contacts = world.step(1 / 30)
            _ = (contacts.time, contacts.point, world.positions, world.velocities, world.stats())
            world.set_velocities(np.array([0]), world.velocities[:1])

    run(100)
    gc.collect()
    objects, resident = len(gc.get_objects()), resident_bytes()
    run(1500)
    gc.collect()
    assert len(gc.get_objects()) - objects < 100
    # Positions alone are 12 kB a step: a leak of any array handed out would exceed this.
    assert resident_bytes() - resident < 4 * 2**20


def test_arrays_handed_out_are_not_kept_alive():
    world = vadop.scene(300, 0.1, 2.0)
    contacts = world.step(1 / 30)
    columns = [weakref.ref(getattr(contacts, c)) for c in ("time", "i", "j", "wall", "point", "normal", "impulse")]
    read_back = [weakref.ref(a) for a in (world.positions, world.velocities, world.ids, world.radii, world.masses)]
    del contacts
    gc.collect()
    assert all(ref() is None for ref in columns + read_back)
