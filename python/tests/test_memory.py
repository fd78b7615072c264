"""No memory growth over many steps, in Rust allocations (resident size) or Python objects; a
request that cannot fit in the memory left raises MemoryError and the interpreter lives on."""

import gc
import os
import subprocess
import sys
import textwrap
import weakref

import numpy as np
import pytest

import vadop


def resident_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


@pytest.mark.skipif(not os.path.exists("/proc/self/statm"), reason="needs Linux /proc")
def test_no_growth_over_many_steps() -> None:
    world = vadop.scene(500, 0.05, 0.5)

    def run(frames: int) -> None:
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


def test_arrays_handed_out_are_not_kept_alive() -> None:
    world = vadop.scene(300, 0.1, 2.0)
    contacts = world.step(1 / 30)
    columns = [weakref.ref(getattr(contacts, c)) for c in ("time", "i", "j", "wall", "point", "normal", "impulse")]
    read_back = [weakref.ref(a) for a in (world.positions, world.velocities, world.ids, world.radii, world.masses)]
    del contacts
    gc.collect()
    assert all(ref() is None for ref in columns + read_back)


# Runs in a fresh interpreter whose address space is capped at what it uses plus 256 MiB (as
# `ulimit -v` would), so that these requests cannot fit whatever the machine's memory.
LIMITED = """
import resource
import numpy as np
import vadop

def vm_size():
    with open("/proc/self/status") as f:
        return next(int(line.split()[1]) * 1024 for line in f if line.startswith("VmSize:"))

hard = resource.getrlimit(resource.RLIMIT_AS)[1]
resource.setrlimit(resource.RLIMIT_AS, (vm_size() + (256 << 20), hard))

def refused(call):
    try:
        call()
    except MemoryError as e:
        print("MemoryError:", e)
    else:
        print("no error")
"""


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs Linux /proc")
def test_requests_too_large_for_the_memory_left_raise_memory_error() -> None:
    body = textwrap.dedent("""
        refused(lambda: vadop.scene(10**8))
        refused(lambda: vadop.scene(10**6))
        n = 10**6
        rng = np.random.default_rng(1)
        refused(lambda: vadop.World(rng.uniform(1, 99, (n, 3)), np.zeros((n, 3)), np.full(n, 0.01), box=100.0))
        # One body crossing its box a thousand times a frame: 5000 wall contacts per frame.
        one = (np.array([[0.5, 0.5, 0.5]]), np.array([[1000.0, 0, 0]]), np.array([0.4]))
        refused(lambda: vadop.detect(*one, box=1.0, dt=1.0, frames=10**6))
        print("alive", len(vadop.scene(100)))
    """)
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    result = subprocess.run([sys.executable, "-c", LIMITED + body], capture_output=True, text=True, env=env, timeout=120)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert len(lines) == 5, result.stdout
    assert lines[0].startswith("MemoryError: a world of 100000000 bodies needs about 59.6 GiB of memory, but only ")
    assert lines[1].startswith("MemoryError: a world of 1000000 bodies needs about 610.4 MiB of memory")
    assert lines[2].startswith("MemoryError: a world of 1000000 bodies needs about")
    assert lines[3].startswith("MemoryError: detect: room for ") and "contacts needs about" in lines[3]
    assert lines[4] == "alive 100"
