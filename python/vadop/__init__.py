"""vadop: exact continuous collision detection of many fast-moving spheres and rigid bodies.

Every contact inside a frame is found, in time order, with its exact time, point and normal,
using velocity-aligned discrete oriented polytopes (Coming & Staadt). Bodies go in and come out
as numpy arrays; the engine is Rust and releases the GIL while it steps. Besides spheres, a
``World`` holds spinning rigid bodies of any shape (``World.add_shape``, ``World.add_bodies``)
and static level geometry (``World.add_static``: triangle meshes, half-spaces).

>>> import numpy as np, vadop
>>> world = vadop.World(np.array([[2.0, 5, 5], [8, 5, 5]]), np.array([[30.0, 0, 0], [0, 0, 0]]),
...                     np.array([0.5, 0.5]), box=10.0)
>>> contacts = world.step(0.2)           # the gap of 5 closes at t = 1/6, inside the frame
>>> contacts.i.tolist(), contacts.j.tolist()
([0], [1])
>>> world.velocities[:, 0].round(12).tolist()   # equal masses: velocities exchanged
[0.0, 30.0]

Lists and tuples work wherever arrays do; the version is the package's:

>>> len(vadop.World([[2, 5, 5], [8, 5, 5]], [[30, 0, 0], [0, 0, 0]], [0.5, 0.5], box=10).step(0.2))
1
>>> vadop.__version__
'0.1.0'

``vadop.plot`` (needs matplotlib: ``pip install vadop[plot]``) draws benchmark figures and a
run's contact timeline; ``vadop.viewer`` records a run and plays it back in the browser.
"""

from ._vadop import WALLS, Contacts, World, __version__, detect, scene

__all__ = ["WALLS", "Contacts", "World", "__version__", "detect", "scene"]
