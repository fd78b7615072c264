"""Type stubs of the vadop extension module (checked against it with mypy's stubtest)."""

from typing import Any, Literal, Optional, Sequence, Union, final, overload

import numpy as np
import numpy.typing as npt

_Float64Array = npt.NDArray[np.float64]
_Int64Array = npt.NDArray[np.int64]
# Body ids: a body's handle as an int, generation << 32 | slot (0, 1, 2 ... until a slot is reused).
# Lists and tuples are read with numpy.asarray wherever an array is taken.
_Number = Union[int, float, np.integer[Any], np.floating[Any]]
_Vectors = Union[_Float64Array, Sequence[Sequence[_Number]]]
_Values = Union[_Float64Array, Sequence[_Number]]
_Box = Union[float, _Float64Array, Sequence[Sequence[_Number]]]
_Vector = _Values
_Ids = Union[int, _Int64Array, Sequence[int]]
# Shape ids: 0, 1, 2 ... in the order World.add_shape made them.
_ShapeIds = Union[int, _Int64Array, Sequence[int]]
_Triangles = Union[_Int64Array, Sequence[Sequence[int]]]
_BoolArray = npt.NDArray[np.bool_]
_MethodName = Literal["auto", "vadop", "grid", "brute", "discrete", "swept-aabb", "swept-kdop"]
_ModeName = Literal["simulate", "detect"]

__all__ = ["WALLS", "Contacts", "World", "__version__", "detect", "scene"]

WALLS: list[str]
__version__: str

@final
class Contacts:
    """The contacts of one or more frames, as columns in time order."""

    @property
    def time(self) -> _Float64Array: ...
    @property
    def i(self) -> _Int64Array: ...
    @property
    def j(self) -> _Int64Array: ...
    @property
    def wall(self) -> _Int64Array: ...
    @property
    def point(self) -> _Float64Array: ...
    @property
    def normal(self) -> _Float64Array: ...
    @property
    def impulse(self) -> _Float64Array: ...
    def __len__(self) -> int: ...

@final
class World:
    """Bodies in a box, stepped frame by frame; every contact inside a frame is found.

    Bodies are spheres (given to the constructor or to add) or rigid bodies of any shape
    (add_shape, then add_bodies, or add_static for fixed level geometry). friction is the Coulomb
    coefficient of every impact (0: frictionless); contact_ends (detect mode only) also reports
    when each contact between bodies ends (contact_ends(), touching()).

    Bodies are named by int ids, 0, 1, 2 ... in row order; a removed body's slot is reused under
    a new id (the slot plus 2**32 per reuse), so a removed body's id raises ValueError and never
    names another body. Arrays read back hold every live body, static ones too, in slot order.

    Threads may share a world: calls on it take turns (steps are serialised by a lock inside the
    world). A thread that calls while another steps waits, without holding the GIL, until that
    step is done. A world that would not fit in the
    memory left raises MemoryError before anything is allocated.
    """

    def __new__(
        cls,
        positions: Optional[_Vectors] = None,
        velocities: Optional[_Vectors] = None,
        radii: Optional[_Values] = None,
        masses: Optional[_Values] = None,
        *,
        box: _Box,
        method: _MethodName = "auto",
        mode: _ModeName = "simulate",
        pool_axes: Optional[int] = None,
        phi: Optional[float] = None,
        restitution: float = 1.0,
        friction: float = 0.0,
        contact_duration: float = 1e-05,
        threads: Optional[int] = None,
        contact_ends: bool = False,
        gravity: tuple[float, float, float] | list[float] | None = None,
        periodic: str | None = None,
    ) -> World: ...
    def add(
        self,
        positions: _Vectors,
        velocities: _Vectors,
        radii: _Values,
        masses: Optional[_Values] = None,
    ) -> _Int64Array: ...
    @overload
    def add_shape(self, kind: Literal["sphere"], *, radius: float) -> int:
        """Adds a shape bodies can then take; returns its id (0, 1, 2 ... in order added)."""
    @overload
    def add_shape(self, kind: Literal["cuboid"], *, half_extents: _Vector) -> int: ...
    @overload
    def add_shape(self, kind: Literal["capsule", "cylinder", "cone"], *, half_height: float, radius: float) -> int: ...
    @overload
    def add_shape(self, kind: Literal["convex_hull"], *, points: _Vectors) -> int: ...
    @overload
    def add_shape(self, kind: Literal["trimesh"], *, vertices: _Vectors, triangles: _Triangles) -> int: ...
    @overload
    def add_shape(self, kind: Literal["halfspace"], *, normal: _Vector) -> int: ...
    def shapes(self) -> list[dict[str, Any]]:
        """The shapes added so far, each as the keyword arguments of add_shape that make it."""
    def shape_surface(self, shape: int) -> tuple[_Float64Array, _Int64Array]:
        """The shape's surface in its own frame, for drawing: (vertices (v, 3), triangles (t, 3))."""
    def add_bodies(
        self,
        shapes: _ShapeIds,
        positions: _Vectors,
        velocities: Optional[_Vectors] = None,
        orientations: Optional[_Vectors] = None,
        angular_velocities: Optional[_Vectors] = None,
        masses: Optional[_Values] = None,
    ) -> _Int64Array:
        """Adds moving rigid bodies of the world's shapes, all or none; returns their ids.

        orientations are quaternions (x, y, z, w); runs without the GIL.
        """
    def add_static(self, shape: int, position: _Vector, orientation: Optional[_Vector] = None) -> int:
        """Adds a static body (level geometry, or any shape fixed in place); returns its id."""
    def remove(self, ids: _Ids) -> None: ...
    def set_velocities(self, ids: _Ids, velocities: _Vectors) -> None: ...
    def set_motions(self, ids: _Ids, velocities: _Vectors, angular_velocities: _Vectors) -> None:
        """Sets the velocities and angular velocities of moving bodies, all or none."""
    def step(self, dt: float) -> Contacts:
        """Advances the world by dt; the frame's contacts in time order.

        Runs without the GIL. A Ctrl-C, before it starts or while it runs (within 50 ms, however
        long the step), raises KeyboardInterrupt and leaves the world as it was before the step;
        another thread's call on this world waits for the step.
        """
    def contact_ends(self) -> Contacts:
        """The contacts between bodies that ended in the last frame, in time order (impulse 0).

        Empty unless the world was made with contact_ends=True (detect mode).
        """
    def touching(self) -> _Int64Array:
        """The pairs in contact now, an int64 (k, 2) array of ids, ascending.

        Empty unless the world was made with contact_ends=True (detect mode).
        """
    @property
    def ids(self) -> _Int64Array: ...
    @property
    def positions(self) -> _Float64Array: ...
    @property
    def periodic(self) -> str: ...
    @property
    def crossings(self) -> _Int64Array: ...
    @property
    def rest(self) -> list[Literal["falling", "sliding", "still"]]:
        """How each body is held up under gravity: 'falling', 'sliding' or 'still'."""
    @property
    def velocities(self) -> _Float64Array: ...
    @property
    def radii(self) -> _Float64Array: ...
    @property
    def masses(self) -> _Float64Array: ...
    @property
    def orientations(self) -> _Float64Array: ...
    @property
    def angular_velocities(self) -> _Float64Array: ...
    @property
    def shape_ids(self) -> _Int64Array: ...
    @property
    def static(self) -> _BoolArray: ...
    @property
    def box(self) -> _Float64Array: ...
    @property
    def time(self) -> float: ...
    @property
    def method(self) -> _MethodName: ...
    @property
    def mode(self) -> _ModeName: ...
    @property
    def pool_axes(self) -> int: ...
    @property
    def phi(self) -> float: ...
    @property
    def restitution(self) -> float: ...
    @property
    def axes(self) -> _Float64Array: ...
    def stats(self) -> dict[str, float]: ...
    def kinetic_energy(self) -> float: ...
    def translational_kinetic_energy(self) -> float: ...
    def potential_energy(self) -> float: ...
    def momentum(self) -> _Float64Array: ...
    def angular_momentum(self) -> _Float64Array: ...
    def volumes(self, dt: float) -> tuple[_Int64Array, _Int64Array, _Float64Array, _Float64Array]: ...
    def __len__(self) -> int: ...

def scene(
    bodies: int = 1000,
    packing_fraction: float = 0.05,
    max_speed: float = 0.5,
    *,
    radius: float = 0.5,
    seed: int = 1,
    method: _MethodName = "auto",
    mode: _ModeName = "simulate",
    pool_axes: Optional[int] = None,
    phi: Optional[float] = None,
    restitution: float = 1.0,
    contact_duration: float = 1e-05,
    threads: Optional[int] = None,
) -> World:
    """The paper's scene as a World; MemoryError when it would not fit in the memory left."""

def detect(
    positions: _Vectors,
    velocities: _Vectors,
    radii: _Values,
    *,
    box: _Box,
    dt: float,
    frames: int,
    method: _MethodName = "auto",
    pool_axes: Optional[int] = None,
    phi: Optional[float] = None,
    threads: Optional[int] = None,
) -> Contacts:
    """Every contact over `frames` frames of `dt` on straight paths, in time order.

    Runs without the GIL; Ctrl-C raises KeyboardInterrupt within 50 ms, inside a long frame too.
    MemoryError when the contacts found so far outgrow the memory left.
    """
