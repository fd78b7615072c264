"""Rigid bodies of any shape from Python: shapes and bodies round-trip through the arrays, static
level geometry stops what reaches it, every continuous method finds the contacts of the
brute-force oracle in a mixed world, and elastic frictionless impacts keep energy and momenta.
Bad input is in test_errors.py."""

import threading
import time
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

import vadop

# The moving shapes under test, each about one unit across (as in the core's tests/shapes.rs).
SHAPES: list[dict[str, Any]] = [
    dict(kind="sphere", radius=0.5),
    dict(kind="cuboid", half_extents=[0.6, 0.3, 0.2]),
    dict(kind="capsule", half_height=0.4, radius=0.2),
    dict(kind="cylinder", half_height=0.3, radius=0.4),
    dict(kind="cone", half_height=0.4, radius=0.35),
    dict(kind="convex_hull", points=[[0.5, 0, 0], [-0.3, 0.4, 0.1], [-0.2, -0.4, 0.2], [0, 0.1, -0.5], [0.1, 0, 0.45]]),
]
# A bumpy square of terrain, 0..10 in x and y at z about 1, as vertices and triangles.
GRID = np.stack(np.meshgrid(np.arange(6), np.arange(6), indexing="ij"), axis=-1).reshape(-1, 2) * 2.0
TERRAIN_VERTICES = np.column_stack([GRID, 1.0 + 0.2 * np.sin(GRID[:, 0] + 2 * GRID[:, 1])])
TERRAIN_TRIANGLES = np.array([[6 * i + k, 6 * (i + 1) + k, 6 * i + k + 1] for i in range(5) for k in range(5)]
                             + [[6 * i + k + 1, 6 * (i + 1) + k, 6 * (i + 1) + k + 1] for i in range(5) for k in range(5)])


def random_orientations(rng: np.random.Generator, n: int) -> npt.NDArray[np.float64]:
    q = rng.normal(size=(n, 4))
    unit: npt.NDArray[np.float64] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return unit


def mixed_world(n: int, speed: float, spin: float, seed: int, **settings: Any) -> vadop.World:
    """Plain spheres and bodies of every shape on a loose lattice (so none overlap), random
    orientations, velocities up to ``speed``, spins up to ``spin``: one body in four a plain sphere."""
    per_side = int(np.ceil(n ** (1 / 3)))
    world = vadop.World(box=2.0 * per_side + 2, **settings)
    shape_ids = [world.add_shape(**shape) for shape in SHAPES]
    rng = np.random.default_rng(seed)
    cells = np.stack(np.meshgrid(*[np.arange(per_side)] * 3, indexing="ij"), axis=-1).reshape(-1, 3)[:n]
    positions = 2.0 + 2.0 * cells
    velocities = rng.uniform(-1, 1, (n, 3)) * speed
    plain = np.arange(n) % 4 == 0
    world.add(positions[plain], velocities[plain], rng.uniform(0.2, 0.5, plain.sum()))
    shaped = int((~plain).sum())
    world.add_bodies(rng.choice(shape_ids, shaped), positions[~plain], velocities[~plain],
                     random_orientations(rng, shaped), rng.uniform(-1, 1, (shaped, 3)) * spin,
                     rng.uniform(0.5, 2.0, shaped))
    return world


def same_rotation(a: npt.NDArray[np.float64], b: npt.NDArray[np.float64]) -> None:
    """Unit quaternions a and b (rows) name the same rotations: q and -q are one rotation."""
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", a, b)), 1.0, atol=1e-12)


def test_every_kind_of_shape_reads_back_as_the_arguments_that_make_it() -> None:
    world = vadop.World(box=10.0)
    kinds = [*SHAPES, dict(kind="trimesh", vertices=TERRAIN_VERTICES, triangles=TERRAIN_TRIANGLES),
             dict(kind="halfspace", normal=[0.0, 0, 2])]
    assert [world.add_shape(**shape) for shape in kinds] == list(range(len(kinds)))
    described = world.shapes()
    for given, shape in zip(kinds, described):
        assert list(shape) == list(given)  # kind first, then the parameters in their order
        for name, value in given.items():
            np.testing.assert_array_equal(shape[name], value, err_msg=name)
    assert described[1]["half_extents"].dtype == np.float64 and described[6]["triangles"].dtype == np.int64
    # add_shape(**shape) makes the same shape again, under the next id.
    again = [world.add_shape(**shape) for shape in described]
    assert again == list(range(len(kinds), 2 * len(kinds)))
    for a, b in zip(described, world.shapes()[len(kinds):]):
        assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)


def test_shape_surfaces_bound_the_shapes_and_face_outwards() -> None:
    world = vadop.World(box=10.0)
    for shape in SHAPES:
        vertices, triangles = world.shape_surface(world.add_shape(**shape))
        assert vertices.dtype == np.float64 and triangles.dtype == np.int64 and triangles.shape[1] == 3
        assert 0 <= triangles.min() and triangles.max() < len(vertices)
        a, b, c = (vertices[triangles[:, k]] for k in range(3))
        outward = np.einsum("ij,ij->i", np.cross(b - a, c - a), (a + b + c) / 3 - vertices.mean(axis=0))
        assert np.all(outward > 0), shape["kind"]
    # A cuboid's surface is its 8 corners exactly; a mesh's, its own triangles.
    vertices, triangles = world.shape_surface(world.add_shape("cuboid", half_extents=[1.0, 2, 3]))
    assert sorted(map(tuple, vertices.tolist())) == sorted((x, y, z) for x in (-1, 1) for y in (-2, 2) for z in (-3, 3))
    mesh = world.add_shape("trimesh", vertices=TERRAIN_VERTICES, triangles=TERRAIN_TRIANGLES)
    vertices, triangles = world.shape_surface(mesh)
    np.testing.assert_array_equal(vertices, TERRAIN_VERTICES)
    np.testing.assert_array_equal(triangles, TERRAIN_TRIANGLES)


def test_bodies_round_trip_through_the_arrays() -> None:
    world = vadop.World([[1.0, 1, 1]], [[0.0, 0, 1]], [0.5], box=20.0, mode="detect")
    brick = world.add_shape("cuboid", half_extents=[1.0, 0.5, 0.25])
    cone = world.add_shape("cone", half_height=1.0, radius=0.5)
    rng = np.random.default_rng(3)
    positions = np.array([[5.0, 5, 5], [10, 10, 10], [15, 15, 15]])
    velocities, spins = rng.normal(size=(3, 3)), rng.normal(size=(3, 3))
    orientations = random_orientations(rng, 3) * [[2.0], [0.5], [1.0]]  # any non-zero length
    ids = world.add_bodies([brick, cone, brick], positions, velocities, orientations, spins, [1.0, 2.0, 3.0])
    assert ids.dtype == np.int64 and ids.tolist() == [1, 2, 3]
    assert world.ids.tolist() == [0, 1, 2, 3] and len(world) == 4
    assert world.shape_ids.tolist() == [-1, brick, cone, brick] and world.shape_ids.dtype == np.int64
    assert world.static.tolist() == [False] * 4 and world.static.dtype == np.bool_
    np.testing.assert_allclose(world.positions, [[1.0, 1, 1], *positions], atol=1e-12)  # the shape's own origin
    np.testing.assert_array_equal(world.velocities, [[0.0, 0, 1], *velocities])
    np.testing.assert_allclose(world.angular_velocities, [[0.0, 0, 0], *spins], atol=1e-12)
    same_rotation(world.orientations, np.vstack([[0.0, 0, 0, 1], orientations / np.linalg.norm(orientations, axis=1, keepdims=True)]))
    np.testing.assert_array_equal(world.masses, [1.0, 1.0, 2.0, 3.0])
    # Radii: the sphere's own; a brick's bounding radius, the length of its half extents; a
    # cone's, from its centre of mass a quarter of the height above the base: 1.5 half heights.
    np.testing.assert_allclose(world.radii, [0.5, np.sqrt(1.3125), 1.5, np.sqrt(1.3125)], rtol=1e-9)
    # Defaults: at rest, unturned, unit mass; one shape id for every body.
    more = world.add_bodies(cone, [[5.0, 15, 5], [15, 5, 5]])
    rows = np.isin(world.ids, more)
    np.testing.assert_array_equal(world.velocities[rows], np.zeros((2, 3)))
    np.testing.assert_array_equal(world.angular_velocities[rows], np.zeros((2, 3)))
    same_rotation(world.orientations[rows], np.array([[0.0, 0, 0, 1]] * 2))
    np.testing.assert_array_equal(world.masses[rows], [1.0, 1.0])
    assert world.shape_ids[rows].tolist() == [cone, cone]
    # Read-backs follow the motion: the brick moved on in a straight line and turned.
    world.step(0.5)
    np.testing.assert_allclose(world.positions[1], positions[0] + 0.5 * velocities[0], atol=1e-9)
    assert world.orientations.shape == (6, 4)
    np.testing.assert_allclose(np.linalg.norm(world.orientations, axis=1), 1.0, atol=1e-12)


def test_huge_and_tiny_orientations_are_rotations() -> None:
    # Regression: a squared length above ~1e308 overflowed ([0, 0, 0, 1e155] became [0, 0, 0, 0],
    # the cube a point) and one below ~1e-308 underflowed (refused as zero).
    orientations = [[0.0, 0, 0, 1e155], [0.0, 0, 0, 1e300], [0.0, 0, 3e-300, 4e-300], [0.0, 0, 5e-324, 0]]
    world = vadop.World(box=10.0, mode="detect")
    cube = world.add_shape("cuboid", half_extents=[0.5, 0.5, 0.5])
    world.add_bodies(cube, [[2.0, 2, 5], [2, 5, 5], [2, 8, 5], [8, 5, 5]], orientations=orientations)
    same_rotation(world.orientations, np.array([[0.0, 0, 0, 1], [0, 0, 0, 1], [0, 0, 0.6, 0.8], [0, 0, 1, 0]]))
    # The cube turned by the huge quaternion collides as a cube: faces 0.5 from its centre.
    hit = vadop.World(box=10.0, mode="detect")
    cube = hit.add_shape("cuboid", half_extents=[0.5, 0.5, 0.5])
    hit.add_bodies(cube, [[2.0, 5, 5], [5, 5, 5]], [[1.0, 0, 0], [0, 0, 0]], [[0.0, 0, 0, 1e155]] * 2)
    assert hit.step(3.0).time.tolist() == pytest.approx([2.0], abs=1e-5)
    for bad in ([0.0, 0, 0, 0], [0.0, 0, 0, np.inf], [np.nan, 0, 0, 1]):
        with pytest.raises(ValueError, match="orientation"):
            world.add_bodies(cube, [[5.0, 2, 5]], orientations=[bad])


def test_a_cones_position_is_its_shape_origin_not_its_centre_of_mass() -> None:
    world = vadop.World(box=10.0, mode="detect")
    cone = world.add_shape("cone", half_height=1.0, radius=0.5)
    # Upright and moving along x: its centre of mass, 0.5 below the origin, moves in a line.
    (body,) = world.add_bodies(cone, [[5.0, 5, 5]], [[1.0, 0, 0]]).tolist()
    world.step(1.0)
    np.testing.assert_allclose(world.positions[0], [6.0, 5, 5], atol=1e-12)
    # Turned upside down about x, spinning about its axis (now along -y): the origin stays put
    # relative to the centre of mass, so it keeps its height.
    world.remove(body)
    world.add_bodies(cone, [[5.0, 5, 5]], orientations=[[1.0, 0, 0, 0]], angular_velocities=[[0.0, -3, 0]])
    world.step(1.0)
    np.testing.assert_allclose(world.positions[0], [5.0, 5, 5], atol=1e-9)


def test_static_bodies_are_level_geometry_that_moving_bodies_bounce_off() -> None:
    world = vadop.World([[5.0, 5, 8]], [[0.0, 0, -6]], [0.5], box=10.0, restitution=1.0)
    terrain = world.add_shape("trimesh", vertices=TERRAIN_VERTICES, triangles=TERRAIN_TRIANGLES)
    floor = world.add_static(terrain, [0.0, 0, 0])
    slab = world.add_static(world.add_shape("cuboid", half_extents=[20.0, 20, 0.5]), [5.0, 5, -1], [0.0, 0, 0.38, 0.92])
    assert world.static.tolist() == [False, True, True]
    np.testing.assert_array_equal(world.masses, [1.0, np.inf, np.inf])
    assert world.radii[1] == np.inf and np.isfinite(world.radii[2])  # a mesh has no bounding sphere
    np.testing.assert_array_equal(world.velocities[1:], np.zeros((2, 3)))
    contacts = world.step(1.5)
    # The ball bounces off the terrain (about z = 1 below it) and goes back up.
    assert contacts.j.tolist()[:1] == [floor] and contacts.i.tolist()[:1] == [0]
    assert world.velocities[0, 2] > 0 and world.positions[0, 2] > 1.5
    # Static bodies never move: a velocity is refused; removing them works like any body.
    with pytest.raises(ValueError, match=f"ids must name moving bodies, got {slab}: a static body"):
        world.set_velocities(slab, [[1.0, 0, 0]])
    world.remove([floor, slab])
    assert world.ids.tolist() == [0] and world.shape_ids.tolist() == [-1]


def test_level_geometry_bounces_bodies_in_detect_mode_too() -> None:
    world = vadop.World([[5.0, 5, 5]], [[0.0, -4, 0]], [0.5], box=10.0, mode="detect")
    world.add_static(world.add_shape("halfspace", normal=[0.0, 1, 0]), [0.0, 2, 0])
    contacts = world.step(1.0)
    assert contacts.j.tolist() == [1] and contacts.time[0] == pytest.approx(0.625, abs=1e-6)
    assert world.velocities[0].tolist() == [0.0, 4.0, 0.0]


def test_set_motions_and_angular_momentum() -> None:
    world = mixed_world(12, 1.0, 1.0, seed=4)
    ids = world.ids[[1, 5]]
    world.set_motions(ids, [[1.0, 0, 0], [0, 2.0, 0]], [[0.0, 0, 3], [1.0, 0, 0]])
    rows = np.isin(world.ids, ids)
    np.testing.assert_array_equal(world.velocities[rows], [[1.0, 0, 0], [0, 2.0, 0]])
    np.testing.assert_allclose(world.angular_velocities[rows], [[0.0, 0, 3], [1.0, 0, 0]], atol=1e-12)
    # One id and one row each, as set_velocities takes them.
    world.set_motions(int(ids[0]), [[0.5, 0, 0]], [[0.0, 0, 0]])
    np.testing.assert_array_equal(world.angular_velocities[np.argmax(rows)], [0.0, 0, 0])
    # set_velocities keeps the spin.
    world.set_velocities(ids[1], [[0.0, 0, 1.0]])
    np.testing.assert_allclose(world.angular_velocities[rows][1], [1.0, 0, 0], atol=1e-12)
    # A spinning sphere's angular momentum: r x m v + (2/5) m r^2 w.
    ball = vadop.World([[1.0, 2, 3]], [[0.0, 0, 0]], [0.5], [2.0], box=10.0)
    ball.set_motions(0, [[1.0, 0, 0]], [[0.0, 4.0, 0]])
    np.testing.assert_allclose(ball.angular_momentum(), np.cross([1.0, 2, 3], [2.0, 0, 0]) + [0, 0.4 * 2 * 0.25 * 4, 0])
    assert ball.kinetic_energy() == pytest.approx(0.5 * 2 * 1 + 0.5 * 0.4 * 2 * 0.25 * 16)


@pytest.mark.parametrize("mode", ["detect", "simulate"])
@pytest.mark.parametrize("method", ["auto", "vadop"])
@pytest.mark.parametrize("gravity", [None, (1.0, -2.0, -15.0)])
def test_a_mixed_world_finds_the_contacts_of_brute_force(mode: Any, method: Any, gravity: Any) -> None:
    # Under gravity too: every shape's path is a parabola, the same bits for every method.
    world = mixed_world(30, 20.0, 15.0, seed=9, method=method, mode=mode, gravity=gravity)
    oracle = mixed_world(30, 20.0, 15.0, seed=9, method="brute", mode=mode, gravity=gravity)
    total = 0
    for frame in range(10):
        found, expected = world.step(0.1), oracle.step(0.1)
        for column in ("time", "i", "j", "wall", "point", "normal", "impulse"):
            np.testing.assert_array_equal(getattr(found, column), getattr(expected, column), err_msg=f"{column}, frame {frame}")
        total += int((found.j >= 0).sum())
    assert total > 5, "too few body contacts to compare"
    for column in ("ids", "positions", "velocities", "orientations", "angular_velocities"):
        np.testing.assert_array_equal(getattr(world, column), getattr(oracle, column), err_msg=column)


def test_shapes_under_gravity_fall_and_come_to_rest() -> None:
    # Elastic: a dropped cuboid bounces on the floor, keeping kinetic plus potential energy.
    world = vadop.World(box=10.0, gravity=(0, 0, -9.81))
    cuboid = world.add_shape("cuboid", half_extents=[0.6, 0.3, 0.2])
    world.add_bodies([cuboid], [[5.0, 5, 4]], [[0.5, 0, 0]], [[0.1, 0.2, 0.3, 0.9]], [[1.0, 2, 0]], [1.0])
    start = world.kinetic_energy() + world.potential_energy()
    walls = 0
    for _ in range(60):
        walls += int((world.step(1 / 30).wall >= 0).sum())
    assert walls > 0
    assert world.kinetic_energy() + world.potential_energy() == pytest.approx(start, rel=1e-12)
    # With restitution below 1 a shape comes to rest: on a static half-space, it lies still on its
    # face there, its spin stopped.
    resting = vadop.World(box=10.0, gravity=(0, 0, -9.81), restitution=0.5, friction=0.3)
    cuboid = resting.add_shape("cuboid", half_extents=[0.6, 0.3, 0.2])
    resting.add_static(resting.add_shape("halfspace", normal=[0.0, 0, 1]), [0.0, 0, 1])
    resting.add_bodies([cuboid], [[5.0, 5, 4]])
    resting.step(3.0)
    assert resting.rest == ["still", "still"]
    assert resting.positions[1, 2] == pytest.approx(1.2, abs=1e-6)
    np.testing.assert_array_equal(resting.angular_velocities[1], [0.0, 0, 0])
    detect = vadop.World(box=10.0, gravity=(0, 0, -9.81), mode="detect")
    detect.add_static(detect.add_shape("halfspace", normal=[0.0, 0, 1]), [0.0, 0, 1])


def test_elastic_frictionless_impacts_keep_energy_and_momenta() -> None:
    # Far from the walls (a large box, a short run): only body impacts act, elastic and frictionless.
    world = vadop.World(box=400.0, restitution=1.0, friction=0.0)
    shape_ids = [world.add_shape(**shape) for shape in SHAPES]
    rng = np.random.default_rng(11)
    cells = np.stack(np.meshgrid(np.arange(4), np.arange(4), np.arange(4), indexing="ij"), axis=-1).reshape(-1, 3)
    positions = (195.0 + 1.6 * cells).astype(np.float64)
    # Towards the cluster's centre, so they collide many times.
    velocities = (197.4 - positions) * 0.6 + rng.uniform(-0.3, 0.3, (64, 3))
    world.add_bodies(np.arange(64) % len(shape_ids), positions, velocities, random_orientations(rng, 64),
                     rng.uniform(-3, 3, (64, 3)), rng.uniform(0.5, 2.0, 64))
    energy, momentum, angular_momentum = world.kinetic_energy(), world.momentum(), world.angular_momentum()
    impacts = 0
    for _ in range(150):
        contacts = world.step(1 / 30)
        assert np.all(contacts.wall == -1), "no wall may be reached"
        impacts += len(contacts)
    assert impacts > 100
    assert world.kinetic_energy() == pytest.approx(energy, rel=1e-9)
    np.testing.assert_allclose(world.momentum(), momentum, rtol=0, atol=1e-9 * (1 + float(np.linalg.norm(momentum))))
    np.testing.assert_allclose(world.angular_momentum(), angular_momentum, rtol=0, atol=1e-9 * float(np.linalg.norm(angular_momentum)))


def test_friction_spins_a_sphere_that_grazes_the_floor() -> None:
    for friction, spins in ((0.0, False), (0.5, True)):
        world = vadop.World([[2.0, 5, 3]], [[4.0, 0, -4]], [0.5], box=10.0, friction=friction, restitution=0.5)
        world.add_static(world.add_shape("halfspace", normal=[0.0, 0, 1]), [0.0, 0, 1])
        world.step(1.0)
        assert (np.linalg.norm(world.angular_velocities[0]) > 1.0) == spins


def test_contact_ends_report_a_bullet_passing_through_a_spinning_box() -> None:
    world = vadop.World(box=20.0, mode="detect", contact_ends=True)
    box = world.add_shape("cuboid", half_extents=[1.0, 1, 1])
    capsule = world.add_shape("capsule", half_height=0.2, radius=0.05)
    (target,) = world.add_bodies(box, [[10.0, 10, 10]], angular_velocities=[[0.0, 0, 5]]).tolist()
    # Lying along x, reaching the box at about 0.09 s and leaving it at about 0.16 s.
    (bullet,) = world.add_bodies(capsule, [[5.0, 10, 10]], [[40.0, 0, 0]], [[0.0, 0, 0.7071, 0.7071]]).tolist()
    starts = world.step(0.1)
    assert (starts.i.tolist(), starts.j.tolist()) == ([target], [bullet])
    assert world.touching().tolist() == [[target, bullet]]
    world.step(0.1)
    ends = world.contact_ends()
    assert (ends.i.tolist(), ends.j.tolist()) == ([target], [bullet]) and ends.time[0] > starts.time[0]
    assert world.touching().shape == (0, 2)


def test_volumes_bound_every_moving_body_about_its_centre_of_mass() -> None:
    world = mixed_world(40, 5.0, 5.0, seed=2, method="vadop")
    world.add_static(world.add_shape("halfspace", normal=[0.0, 0, 1]), [0.0, 0, 0.5])
    world.step(1 / 30)
    body, axis, lo, hi = world.volumes(1 / 30)
    moving = world.ids[~world.static]
    assert set(body.tolist()) == set(moving.tolist())
    # Every point of a body lies within its radius of its centre of mass; its origin too.
    rows = np.searchsorted(world.ids, body)
    radii, axes = world.radii[rows], world.axes[axis]
    start = np.einsum("ij,ij->i", world.positions[rows], axes)
    end = start + np.einsum("ij,ij->i", world.velocities[rows], axes) / 30
    assert np.all(lo <= np.minimum(start, end)) and np.all(hi >= np.maximum(start, end))
    assert np.all(hi - lo <= np.abs(end - start) + 2 * radii * (1 + 1e-9))


def test_add_bodies_releases_the_gil() -> None:
    # As test_world.py's test_step_releases_the_gil: the longest stretch the main thread was kept
    # from running while another thread added bodies, against the time the call took. Only the
    # reading of the arrays holds the GIL; placing each shape in the box does not.
    world = vadop.World(box=1000.0, mode="detect")
    brick = world.add_shape("cuboid", half_extents=[0.5, 0.3, 0.2])
    positions = np.random.default_rng(1).uniform(2, 998, (200_000, 3))
    took: list[float] = []

    def add() -> None:
        started = time.perf_counter()
        world.add_bodies(brick, positions)
        took.append(time.perf_counter() - started)

    worker = threading.Thread(target=add)
    longest_gap, last = 0.0, time.perf_counter()
    worker.start()
    while worker.is_alive():
        now = time.perf_counter()
        longest_gap, last = max(longest_gap, now - last), now
    worker.join()
    assert took and longest_gap < 0.5 * took[0], (longest_gap, took)
