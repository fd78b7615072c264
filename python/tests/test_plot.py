"""Plot helpers draw what they say from real runs and from the benchmark CSV."""

import matplotlib
from pathlib import Path

matplotlib.use("Agg")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

import vadop  # noqa: E402
import vadop.plot  # noqa: E402

CSV = """n,speed,method,frames,status,median_ms,mean_ms,p95_ms,contacts_per_frame,contacts_per_second,peak_mib,reference,missed,extra,reference_pairs,vadop_vs_discrete,vadop_vs_brute
1000,0.5,vadop,10,ok,1.5,,,,,,,,,,,
10000,0.5,vadop,10,ok,14,,,,,,,,,,,
1000,0.5,brute,10,ok,40,,,,,,,,,,,
10000,0.5,brute,10,timed out after 60 s,,,,,,,,,,,,
1000,5,vadop,10,ok,3,,,,,,,,,,,
1000,5,discrete,10,ok,0.5,,,,,,,,,,,
"""


def bars(ax: Axes) -> list[Rectangle]:
    """The bars of a bar chart (every patch of ``ax`` is one)."""
    found = [p for p in ax.patches if isinstance(p, Rectangle)]
    assert len(found) == len(ax.patches)
    return found


def test_benchmark_figure_has_a_panel_per_speed_and_a_line_per_method(tmp_path: Path) -> None:
    path = tmp_path / "bench.csv"
    path.write_text(CSV)
    figure = vadop.plot.benchmark(path)
    panels = figure.axes
    assert len(panels) == 2
    assert sorted(str(line.get_label()) for line in panels[0].lines) == ["brute", "vadop"]
    assert sorted(str(line.get_label()) for line in panels[1].lines) == ["discrete", "vadop"]
    vadop_line = next(line for line in panels[0].lines if line.get_label() == "vadop")
    assert np.asarray(vadop_line.get_xdata()).tolist() == [1000, 10000]
    assert np.asarray(vadop_line.get_ydata()).tolist() == [1.5, 14.0]
    path.write_text(CSV.splitlines()[0] + "\n")
    with pytest.raises(ValueError, match="no successful benchmark rows"):
        vadop.plot.benchmark(path)


def test_contact_timeline_and_cost_split_from_a_run() -> None:
    world = vadop.scene(200, 0.1, 2.0)
    frames, stats = [], []
    for _ in range(8):
        frames.append(world.step(1 / 30))
        stats.append(world.stats())
    total = sum(len(f) for f in frames)
    pairs = sum(int((f.j >= 0).sum()) for f in frames)
    figure = vadop.plot.contact_timeline(frames, dt=1 / 30)
    timeline, counts = figure.axes
    body_body, wall = timeline.collections
    assert len(np.asarray(body_body.get_offsets())) == 2 * pairs and len(np.asarray(wall.get_offsets())) == total - pairs
    assert sum(bar.get_height() for bar in bars(counts)) == total
    assert f"{total} contacts" in timeline.get_title()
    split = vadop.plot.cost_split(stats)
    assert len(split.axes[0].patches) == 4 * 8
    with pytest.raises(ValueError, match="at least one frame"):
        vadop.plot.cost_split([])


def test_cost_split_takes_one_frames_stats_as_the_readme_shows() -> None:
    # Issue 15: cost_split(world.stats()) raised TypeError; stats() is one frame's dict.
    world = vadop.scene(200, 0.1, 2.0)
    world.step(1 / 30)
    stats = world.stats()
    assert isinstance(stats, dict)
    figure = vadop.plot.cost_split(stats)
    assert len(figure.axes[0].patches) == 4
    heights = sorted(bar.get_height() for bar in bars(figure.axes[0]))
    stages = sorted(stats[s] * 1e3 for s in ("update_seconds", "sort_seconds", "test_seconds", "response_seconds"))
    assert heights == pytest.approx(stages)
    # A tuple of them works like a list; anything else says what was expected.
    assert len(vadop.plot.cost_split((stats, stats)).axes[0].patches) == 8
    with pytest.raises(TypeError, match="stats must be a World.stats\\(\\) dict or a list of them, got float at \\[0\\]"):
        vadop.plot.cost_split([1.0])  # type: ignore[list-item]
    with pytest.raises(ValueError, match="stats\\[0\\] is not a World.stats\\(\\) dict: it lacks sort_seconds"):
        vadop.plot.cost_split({"update_seconds": 1.0, "test_seconds": 1.0, "response_seconds": 1.0})
