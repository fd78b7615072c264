"""Plot helpers draw what they say from real runs and from the benchmark CSV."""

import matplotlib

matplotlib.use("Agg")

import pytest  # noqa: E402

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


def test_benchmark_figure_has_a_panel_per_speed_and_a_line_per_method(tmp_path):
    path = tmp_path / "bench.csv"
    path.write_text(CSV)
    figure = vadop.plot.benchmark(path)
    panels = figure.axes
    assert len(panels) == 2
    assert sorted(line.get_label() for line in panels[0].lines) == ["brute", "vadop"]
    assert sorted(line.get_label() for line in panels[1].lines) == ["discrete", "vadop"]
    vadop_line = next(line for line in panels[0].lines if line.get_label() == "vadop")
    assert list(vadop_line.get_xdata()) == [1000, 10000] and list(vadop_line.get_ydata()) == [1.5, 14.0]
    path.write_text(CSV.splitlines()[0] + "\n")
    with pytest.raises(ValueError, match="no successful benchmark rows"):
        vadop.plot.benchmark(path)


def test_contact_timeline_and_cost_split_from_a_run():
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
    assert len(body_body.get_offsets()) == 2 * pairs and len(wall.get_offsets()) == total - pairs
    assert sum(p.get_height() for p in counts.patches) == total
    assert f"{total} contacts" in timeline.get_title()
    split = vadop.plot.cost_split(stats)
    assert len(split.axes[0].patches) == 4 * 8
    with pytest.raises(ValueError, match="at least one frame"):
        vadop.plot.cost_split([])
