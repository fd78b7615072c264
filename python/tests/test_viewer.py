"""The viewer: a recording holds what the page needs, and the page renders in a real browser
(headless Chromium with its software WebGL): the screenshot is checked for its content."""

import html
import json
import os
import shutil
import subprocess
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest
from matplotlib.image import imread

import vadop
from vadop.viewer import main, record, write_html


def test_recording_holds_frames_contacts_and_honest_volumes() -> None:
    world = vadop.scene(80, 0.1, 2.0, method="vadop", pool_axes=7)
    run = record(world, frames=6, watch=[3, 5])
    assert len(run["frames"]) == 7 and run["frames"][0]["v"] is None
    assert len(run["axes"]) == 7 and run["ids"] == list(range(80))
    assert sum(len(f["c"]) for f in run["frames"]) > 0
    for frame in run["frames"][1:]:
        p = np.array(frame["p"]).reshape(-1, 3)
        u = np.array(frame["u"]).reshape(-1, 3)
        assert {v[0] for v in frame["v"]} == {3, 5}
        for body, axis, lo, hi in frame["v"]:
            a = np.array(run["axes"][axis])
            start, end = p[body] @ a, p[body] @ a + u[body] @ a * run["dt"]
            tolerance = 1e-4  # the recording rounds to 1e-5 of the box
            assert lo <= min(start, end) - 0.5 + tolerance and hi >= max(start, end) + 0.5 - tolerance
            # A VADOP axis is nearly orthogonal to the body's velocity.
            assert abs(u[body] @ a) <= np.linalg.norm(u[body]) * np.sin(world.phi) + 1e-3


def test_other_methods_record_without_volumes(tmp_path: Path) -> None:
    run = record(vadop.scene(30, 0.1, 1.0, method="brute"), frames=2)
    assert all(f["v"] is None for f in run["frames"])
    page = write_html(run, tmp_path / "run.html").read_text()
    assert "/*VADOP_DATA*/" not in page and '"method":"brute"' in page


def test_command_writes_a_page(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "run.html"
    assert main(["--bodies", "40", "--frames", "5", "--out", str(out)]) == 0
    assert out.exists() and "wrote" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exit:
        main(["--bodies", "0", "--out", str(out)])
    assert exit.value.code == 2


def chromium() -> str:
    found = shutil.which("chromium") or shutil.which("chromium-browser") or shutil.which("google-chrome")
    if found is None:
        if os.environ.get("CI"):
            pytest.fail("chromium is required in CI (scripts/test.sh installs it with apt-get)")
        pytest.skip("chromium not installed (apt-get install -y chromium)")
    return found


def browse(page: Path, fragment: str, *args: str) -> str:
    command = [chromium(), "--headless", "--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
               "--window-size=1000,700", "--hide-scrollbars", "--virtual-time-budget=4000", *args,
               page.resolve().as_uri() + "#" + fragment]
    return subprocess.run(command, capture_output=True, text=True, timeout=180, check=True).stdout


@pytest.fixture(scope="module")
def page(tmp_path_factory: pytest.TempPathFactory) -> Path:
    world = vadop.scene(150, 0.08, 1.5, seed=2, method="vadop")
    return write_html(record(world, frames=40), tmp_path_factory.mktemp("viewer") / "run.html")


def test_page_runs_without_errors(page: Path) -> None:
    dom = browse(page, "frame=20&body=7&pause", "--dump-dom")
    status = json.loads(html.unescape(dom.split('data-status="', 1)[1].split('"', 1)[0]))
    assert status["error"] == "" and status["gl"] == "webgl2"
    assert status["rendered"] >= 1 and status["frame"] == 20 and status["body"] == 7
    assert status["slabs"] >= 2  # a body uses at least two axes of the 3-axis pool


def mixed_world() -> vadop.World:
    """Plain spheres and spinning bodies of every moving shape over a static terrain mesh, with a
    half-space wall and a static box: 4 + 6 moving bodies, 3 static."""
    world = vadop.World([[2.0, 2, 6], [4, 2, 6], [6, 2, 6], [8, 2, 6]], np.zeros((4, 3)), np.full(4, 0.4),
                        box=10.0, mode="detect")
    kinds: list[dict[str, Any]] = [
        dict(kind="sphere", radius=0.4),
        dict(kind="cuboid", half_extents=[0.6, 0.3, 0.2]),
        dict(kind="capsule", half_height=0.4, radius=0.2),
        dict(kind="cylinder", half_height=0.3, radius=0.4),
        dict(kind="cone", half_height=0.4, radius=0.35),
        dict(kind="convex_hull", points=[[0.5, 0, 0], [-0.3, 0.4, 0.1], [-0.2, -0.4, 0.2], [0, 0.1, -0.5], [0.1, 0, 0.45]]),
    ]
    shapes = [world.add_shape(**kind) for kind in kinds]
    rng = np.random.default_rng(5)
    world.add_bodies(shapes, [[2.0 + 1.5 * k, 6, 6] for k in range(6)], rng.normal(size=(6, 3)),
                     rng.normal(size=(6, 4)), rng.normal(scale=3.0, size=(6, 3)))
    grid = np.stack(np.meshgrid(np.arange(4), np.arange(4), indexing="ij"), axis=-1).reshape(-1, 2) * 10 / 3
    terrain = world.add_shape("trimesh", vertices=np.column_stack([grid, 1 + 0.3 * np.cos(grid.sum(axis=1))]),
                              triangles=[[4 * i + k, 4 * i + k + 4, 4 * i + k + 1] for i in range(3) for k in range(3)]
                              + [[4 * i + k + 1, 4 * i + k + 4, 4 * i + k + 5] for i in range(3) for k in range(3)])
    world.add_static(terrain, [0.0, 0, 0])
    world.add_static(world.add_shape("halfspace", normal=[-1.0, 0, 0]), [10.0, 0, 0])
    world.add_static(shapes[1], [5.0, 9, 5], [0.0, 0, 0.38, 0.92])
    return world


def test_recording_keeps_shapes_orientations_and_level_geometry() -> None:
    world = mixed_world()
    run = record(world, frames=3)
    assert run["shape_ids"] == [-1] * 4 + list(range(6)) + [6, 7, 1]
    assert run["static"] == [False] * 10 + [True] * 3
    assert run["radii"][10] is None and run["radii"][11] is None and run["radii"][12] is not None
    kinds = [shape["kind"] for shape in run["shapes"]]
    assert kinds == ["sphere", "cuboid", "capsule", "cylinder", "cone", "convex_hull", "trimesh", "halfspace"]
    assert run["shapes"][0] == {"kind": "sphere", "radius": 0.4}
    assert run["shapes"][7] == {"kind": "halfspace", "normal": [-1.0, 0.0, 0.0]}
    for shape in run["shapes"][1:7]:
        assert len(shape["vertices"]) % 3 == 0 and len(shape["triangles"]) % 3 == 0
        assert max(shape["triangles"]) < len(shape["vertices"]) // 3
    for frame in run["frames"]:
        q = np.array(frame["q"]).reshape(-1, 4)
        assert q.shape == (13, 4)
        np.testing.assert_allclose(np.linalg.norm(q, axis=1), 1.0, atol=1e-5)
    # The bodies turn; the static ones stay as they were.
    first, last = np.array(run["frames"][0]["q"]).reshape(-1, 4), np.array(run["frames"][-1]["q"]).reshape(-1, 4)
    assert not np.allclose(np.abs(np.sum(first[4:10] * last[4:10], axis=1)), 1.0)
    np.testing.assert_array_equal(first[10:], last[10:])
    # A page is valid JSON inside: no infinities.
    json.dumps(run, allow_nan=False)


@pytest.fixture(scope="module")
def mixed_page(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_html(record(mixed_world(), frames=20), tmp_path_factory.mktemp("viewer") / "mixed.html")


def test_a_mixed_shape_page_draws_every_body(mixed_page: Path) -> None:
    dom = browse(mixed_page, "frame=10&body=5&pause", "--dump-dom")
    status = json.loads(html.unescape(dom.split('data-status="', 1)[1].split('"', 1)[0]))
    assert status["error"] == "" and status["gl"] == "webgl2" and status["rendered"] >= 1
    # 4 plain spheres and one "sphere" shape as spheres, 5 moving solids, and 3 pieces of level
    # geometry: the terrain, the half-space and the static box.
    assert (status["spheres"], status["solids"], status["level"]) == (5, 5, 3)
    assert status["frame"] == 10 and status["body"] == 5


def test_a_mixed_shape_screenshot_shows_solids_and_level_geometry(mixed_page: Path, tmp_path: Path) -> None:
    image = screenshot(mixed_page, "frame=10&body=5&pause&volumes=0", tmp_path / "mixed.png")
    r, g, b = image[:640, 340:, 0], image[:640, 340:, 1], image[:640, 340:, 2]
    # Blue-grey moving bodies, the orange selected cuboid, and the green-grey level geometry.
    moving = (b > r + 0.08) & (b > 0.3)
    selected = (r > 0.4) & (g > 0.4 * r) & (g < 0.7 * r) & (b < 0.25 * r)
    level = (g > b + 0.05) & (g > r) & (g > 0.2)
    assert moving.sum() > 2000 and selected.sum() > 50 and level.sum() > 5000


def test_a_periodic_box_draws_a_sphere_on_both_sides_of_its_face(tmp_path: Path) -> None:
    # The first sphere reaches across the face at x = 0: it shows there and by x = 10.
    world = vadop.World([[0.2, 5, 5], [5.0, 5, 5]], np.zeros((2, 3)), [0.5, 0.5], box=10.0, periodic="x")
    run = record(world, frames=2)
    assert run["periodic"] == [True, False, False]
    page = write_html(run, tmp_path / "periodic.html")
    dom = browse(page, "frame=1&pause", "--dump-dom")
    status = json.loads(html.unescape(dom.split('data-status="', 1)[1].split('"', 1)[0]))
    assert status["error"] == "" and status["spheres"] == 2 and status["images"] == 1


def screenshot(page: Path, fragment: str, path: Path) -> npt.NDArray[np.float32]:
    browse(page, fragment, f"--screenshot={path}")
    return imread(path)[:, :, :3]


def test_screenshot_shows_spheres_box_and_the_selected_volume(page: Path, tmp_path: Path) -> None:
    with_volume = screenshot(page, "frame=20&body=7&pause", tmp_path / "volume.png")
    without = screenshot(page, "frame=20&body=7&pause&volumes=0", tmp_path / "plain.png")
    assert with_volume.shape == (700, 1000, 3)
    r, g, b = with_volume[..., 0], with_volume[..., 1], with_volume[..., 2]
    scene = with_volume[:640, 340:]  # right of the panel, above the controls
    background = np.all(np.abs(scene - np.array([16, 19, 26]) / 255) < 0.03, axis=-1)
    assert 0.3 < background.mean() < 0.97, "the scene is neither empty nor covered"
    # Lit blue-grey spheres, the orange selected body, and the light box edges.
    spheres = (b > r + 0.08) & (b > 0.3)
    selected = (r > 0.4) & (g > 0.4 * r) & (g < 0.7 * r) & (b < 0.25 * r)
    assert spheres.sum() > 5000 and selected.sum() > 20
    edges = np.all(with_volume > 0.6, axis=-1) & (np.abs(r - b) < 0.12)
    assert edges[:640, 340:].sum() > 300
    # The slabs of the selected body's two axes (red for axis 0, green for axis 1) appear only
    # with volumes on, and near the selected body.
    def slab_pixels(image: npt.NDArray[np.float32]) -> tuple[npt.NDArray[np.bool_], npt.NDArray[np.bool_]]:
        r, g, b = image[:640, 340:, 0], image[:640, 340:, 1], image[:640, 340:, 2]
        return (r > 0.5) & (g < 0.6 * r) & (b > 0.25 * r) & (b < 0.5 * r), (g > 0.5) & (r < 0.7 * g) & (b < 0.7 * g)
    (red, green), (red_before, green_before) = slab_pixels(with_volume), slab_pixels(without)
    assert red.sum() > red_before.sum() + 100 and green.sum() > green_before.sum() + 100
    ys, xs = np.nonzero(selected[:640, 340:])
    new_red = red & ~red_before
    ry, rx = np.nonzero(new_red)
    assert abs(np.median(ry) - np.median(ys)) < 120 and abs(np.median(rx) - np.median(xs)) < 120
