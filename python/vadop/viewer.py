"""Record a run and play it back in the browser.

``record`` steps a world and keeps, per frame, every body's position, velocity and (when the
world holds shapes) orientation, the frame's contacts and the VADOP volumes (the pool axes each
body uses and its interval on each) of the frame about to start; once, the world's shapes as
surfaces to draw. ``write_html`` turns a recording into one self-contained HTML page with a
WebGL renderer: spheres and solids of every shape turning in their box, static meshes and
half-spaces as level geometry, contacts flashing, play/pause and scrub, and the volume of a
selected body drawn as its slabs. ``main`` is the ``vadop-view`` command::

    vadop-view --bodies 200 --max-speed 2 --frames 150 --out run.html

>>> import vadop
>>> from vadop.viewer import record
>>> run = record(vadop.scene(50, 0.1, 1.0), frames=3)
>>> len(run["frames"]), len(run["radii"])
(4, 50)
"""

from __future__ import annotations

import argparse
import json
import operator
import webbrowser
from importlib.resources import files
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from ._vadop import World, scene

__all__ = ["record", "write_html", "main"]

# Volumes of every body are kept for worlds up to this size; larger runs keep the first ones only,
# so the page stays a few megabytes.
DEFAULT_WATCHED = 300

# Most frames a recording holds: nine hours at 30 frames per second. The page holds every frame,
# and one of more would not load in a browser long before this.
MAX_FRAMES = 1_000_000


def _int_arg(value: Any, name: str, minimum: int, maximum: int) -> int:
    """``value`` as an int in ``minimum..=maximum``: TypeError if it is not an int (a float
    neither, even 1.0), ValueError naming ``name`` and the range if it lies outside."""
    expected = f"{name} must be an int between {minimum} and {maximum}"
    try:
        number = operator.index(value)
    except TypeError:
        raise TypeError(f"{expected}, got {type(value).__name__}") from None
    if not minimum <= number <= maximum:
        raise ValueError(f"{expected}, got {number}")
    return number


def _rounded(values: np.ndarray[Any, Any], digits: int) -> list[float]:
    return [float(v) for v in np.round(values, digits).ravel()]


# Orientations are kept to 1e-6: far below a pixel's turn for any body on screen.
ORIENTATION_DIGITS = 6


def _drawable(world: World, shape_id: int, shape: dict[str, Any], digits: int) -> dict[str, Any]:
    """What the page needs to draw shape ``shape_id``: a sphere's radius (spheres are drawn as
    spheres), a half-space's normal, any other shape's surface triangles (flat vertex
    coordinates in the shape's frame, flat vertex indices)."""
    kind = shape["kind"]
    if kind == "sphere":
        return {"kind": kind, "radius": float(shape["radius"])}
    if kind == "halfspace":
        return {"kind": kind, "normal": [float(v) for v in shape["normal"]]}
    vertices, triangles = world.shape_surface(shape_id)
    return {"kind": kind, "vertices": _rounded(vertices, digits), "triangles": triangles.ravel().tolist()}


def record(
    world: World,
    frames: int = 150,
    dt: float = 1.0 / 30.0,
    watch: Optional[Sequence[int]] = None,
) -> dict[str, Any]:
    """Steps ``world`` ``frames`` times by ``dt`` and returns the run as a JSON-ready dict.

    ``frames`` is an int from 1 to ``MAX_FRAMES``. ``watch`` lists the ids (ints) of live bodies
    whose volumes are kept (default: all of them, up to ``DEFAULT_WATCHED``). Volumes exist for
    method 'vadop' from the first step on, so frame 0 has none. Bodies must not be added or
    removed while recording.

    Per body, once: ``ids``, ``radii`` (None for level geometry, which has no bounding radius),
    ``shape_ids`` (-1 for plain spheres) and ``static``; ``shapes``, the world's shapes to draw.
    Per frame: ``t``, the positions ``p`` and velocities ``u`` (flat, 3 per body), the
    orientations ``q`` (flat quaternions x, y, z, w; only when the world holds shapes), the
    contacts ``c`` and the volumes ``v``.

    >>> import vadop
    >>> from vadop.viewer import record
    >>> run = record(vadop.scene(20, 0.1, 1.0, method="vadop"), frames=2, watch=[0, 1])
    >>> sorted({row[0] for row in run["frames"][1]["v"]})
    [0, 1]

    A world of shapes keeps their surfaces and the bodies' orientations:

    >>> w = vadop.World([[2.0, 5, 5]], [[1.0, 0, 0]], [0.5], box=10.0)
    >>> _ = w.add_bodies(w.add_shape("cuboid", half_extents=[0.5, 0.5, 0.5]), [[6.0, 5, 5]], angular_velocities=[[0, 0, 1.0]])
    >>> run = record(w, frames=2)
    >>> run["shape_ids"], run["shapes"][0]["kind"], len(run["shapes"][0]["triangles"]) // 3, len(run["frames"][2]["q"])
    ([-1, 0], 'cuboid', 12, 8)
    """
    frames = _int_arg(frames, "frames", 1, MAX_FRAMES)
    ids = world.ids
    if watch is None:
        watched = set(int(i) for i in ids[:DEFAULT_WATCHED])
    elif isinstance(watch, (str, bytes)):
        raise TypeError(f"watch must be a sequence of body ids (ints), got {type(watch).__name__}")
    else:
        watched = {_int_arg(i, f"watch[{k}]", 0, 2**63 - 1) for k, i in enumerate(watch)}
        dead = sorted(watched.difference(ids.tolist()))
        if dead:
            raise ValueError(f"watch must name live bodies, got {dead[0]}")
    extent = float(np.max(world.box[1] - world.box[0]))
    # Positions to 1e-5 of the box: far below a pixel, and the page stays small.
    digits = max(0, int(np.ceil(5 - np.log10(extent))))

    shape_ids = world.shape_ids
    # Spheres look the same however they turn: a world of plain spheres keeps no orientations.
    turning = bool((shape_ids >= 0).any())

    def state(contacts: Optional[Any], volumes: Optional[list[list[float]]]) -> dict[str, Any]:
        c: list[list[float]] = []
        if contacts is not None:
            for i, j, point in zip(contacts.i, contacts.j, contacts.point):
                c.append([int(i), int(j), *_rounded(point, digits)])
        frame = {
            "t": world.time,
            "p": _rounded(world.positions, digits),
            "u": _rounded(world.velocities, digits),
            "c": c,
            "v": volumes,
        }
        if turning:
            frame["q"] = _rounded(world.orientations, ORIENTATION_DIGITS)
        return frame

    run: dict[str, Any] = {
        "box": world.box.tolist(),
        # Spheres reaching across a periodic face are drawn on both sides.
        "periodic": [axis in world.periodic for axis in "xyz"],
        "dt": dt,
        "ids": ids.tolist(),
        # JSON has no infinity: level geometry's radius is None.
        "radii": [float(r) if np.isfinite(r) else None for r in world.radii],
        "shape_ids": shape_ids.tolist(),
        "static": world.static.tolist(),
        "shapes": [_drawable(world, k, shape, digits) for k, shape in enumerate(world.shapes())],
        "axes": world.axes.tolist(),
        "method": world.method,
        "mode": world.mode,
        "frames": [state(None, None)],
    }
    for _ in range(frames):
        contacts = world.step(dt)
        volumes = None
        if world.method == "vadop":
            body, axis, lo, hi = world.volumes(dt)
            keep = np.isin(body, list(watched))
            volumes = [
                [int(b), int(a), round(float(low), digits), round(float(high), digits)]
                for b, a, low, high in zip(body[keep], axis[keep], lo[keep], hi[keep])
            ]
        run["frames"].append(state(contacts, volumes))
    return run


def write_html(run: dict[str, Any], path: str | Path) -> Path:
    """Writes the recording as a self-contained HTML page and returns its path.

    >>> import tempfile, pathlib, vadop
    >>> from vadop.viewer import record, write_html
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run.html"
    >>> write_html(record(vadop.scene(20, 0.1, 1.0), frames=2), out).read_text().startswith("<!")
    True
    """
    template = files("vadop").joinpath("viewer.html").read_text(encoding="utf-8")
    page = template.replace("/*VADOP_DATA*/null", json.dumps(run, separators=(",", ":")), 1)
    out = Path(path)
    out.write_text(page, encoding="utf-8")
    return out


def main(argv: Optional[Sequence[str]] = None) -> int:
    """The ``vadop-view`` command: records the paper's scene and writes the viewer page.

    ``argv`` are the command's options (default: ``sys.argv[1:]``); returns the exit code, and
    exits with code 2 and one ``error:`` line on bad options.

    >>> import tempfile, pathlib
    >>> from vadop.viewer import main
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "run.html"
    >>> main(["--bodies", "20", "--frames", "2", "--out", str(out)])  # doctest: +ELLIPSIS
    wrote ... MB): open it in a browser
    0
    """
    parser = argparse.ArgumentParser(prog="vadop-view", description=__doc__.split("\n\n")[0] if __doc__ else None)
    parser.add_argument("--bodies", type=int, default=200, help="number of spheres (default 200)")
    parser.add_argument("--packing-fraction", type=float, default=0.05, help="fraction of the box filled (default 0.05)")
    parser.add_argument("--max-speed", type=float, default=1.0, help="top speed in diameters per frame (default 1)")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--frames", type=int, default=150, help="frames to record at 30 per second (default 150)")
    parser.add_argument("--mode", choices=["simulate", "detect"], default="simulate")
    parser.add_argument("--pool-axes", type=int, default=None, help="axis pool size (default: the engine's)")
    parser.add_argument("--out", default="vadop-run.html", help="page to write (default vadop-run.html)")
    parser.add_argument("--open", action="store_true", help="open the page in the default browser")
    args = parser.parse_args(argv)
    try:
        world = scene(args.bodies, args.packing_fraction, args.max_speed, seed=args.seed, method="vadop", mode=args.mode, pool_axes=args.pool_axes)
        path = write_html(record(world, args.frames), args.out)
    except (ValueError, OSError) as e:
        # Out-of-range integers and unwritable paths are the user's input too: one line, exit 2.
        parser.exit(2, f"error: {e}\n")
    print(f"wrote {path} ({path.stat().st_size / 1e6:.1f} MB): open it in a browser")
    if args.open:
        webbrowser.open(path.resolve().as_uri())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
