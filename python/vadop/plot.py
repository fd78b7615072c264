"""Plots: the benchmark figures and a run's contact timeline (needs matplotlib: ``vadop[plot]``).

Every function draws into a new figure (or the axes given) and returns the figure, so scripts
can save it and notebooks show it.

- ``benchmark(csv)``: median cost per frame against the number of bodies, one line per method and
  one panel per speed, from the CSV that ``vadop-bench core`` writes (``results/core-benchmark.csv``).
- ``cost_split(stats)``: the per-frame cost split c_update / c_sort / c_test / c_response from
  one ``World.stats()`` dict or a list of them.
- ``contact_timeline(contacts)``: when each body touched something, body-body and wall contacts
  apart, with the number of contacts per frame underneath.

>>> import vadop, vadop.plot
>>> world = vadop.scene(300, 0.1, 2.0)
>>> frames = [world.step(1 / 30) for _ in range(10)]
>>> figure = vadop.plot.contact_timeline(frames, dt=1 / 30)
"""

from __future__ import annotations

import csv
from collections import defaultdict
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Optional, Sequence, Union, cast

import numpy as np

from ._vadop import Contacts

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = ["benchmark", "cost_split", "contact_timeline"]

STAGES = ("update_seconds", "sort_seconds", "test_seconds", "response_seconds")


def _pyplot() -> Any:
    try:
        import matplotlib.pyplot as plt
    except ImportError as e:  # the extra is optional: say how to get it
        raise ImportError("vadop.plot needs matplotlib: pip install 'vadop[plot]'") from e
    return plt


def benchmark(csv_path: Union[str, Path] = "results/core-benchmark.csv") -> Figure:
    """Median c_total per frame (ms) against bodies, per method, one panel per speed.

    ``csv_path`` is a CSV written by ``vadop-bench core`` (columns n, speed, method, status,
    median_ms); rows whose status is not ``ok`` are left out.

    >>> import vadop.plot
    >>> figure = vadop.plot.benchmark("results/core-benchmark.csv")  # doctest: +SKIP
    >>> figure.savefig("benchmark.png")                               # doctest: +SKIP
    """
    rows = [r for r in csv.DictReader(open(csv_path, newline="")) if r.get("status") == "ok" and r.get("median_ms")]
    if not rows:
        raise ValueError(f"{csv_path} has no successful benchmark rows (run `vadop-bench core` first)")
    speeds = sorted({float(r["speed"]) for r in rows})
    plt = _pyplot()
    figure, axes = plt.subplots(1, len(speeds), figsize=(4.2 * len(speeds), 3.8), squeeze=False, sharey=True)
    for ax, speed in zip(axes[0], speeds):
        lines: dict[str, list[tuple[int, float]]] = defaultdict(list)
        for r in rows:
            if float(r["speed"]) == speed:
                lines[r["method"]].append((int(r["n"]), float(r["median_ms"])))
        for method, points in sorted(lines.items()):
            points.sort()
            ax.plot([p[0] for p in points], [p[1] for p in points], marker="o", label=method)
        ax.set(xscale="log", yscale="log", xlabel="bodies", title=f"speed up to {speed:g} diameters/frame")
        ax.grid(True, which="both", alpha=0.3)
    axes[0][0].set_ylabel("median c_total per frame (ms)")
    axes[0][0].legend()
    figure.tight_layout()
    return cast("Figure", figure)


def cost_split(
    stats: Union[Mapping[str, float], Sequence[Mapping[str, float]]],
    ax: Optional[Axes] = None,
) -> Figure:
    """Stacked per-frame cost (ms) of the four stages: update, sort, test and response.

    ``stats`` is what ``World.stats()`` returns after a step (one frame's dict) or a list of
    them, one per frame, drawn left to right.

    >>> import vadop, vadop.plot
    >>> world = vadop.scene(300, 0.1, 2.0)
    >>> _ = world.step(1 / 30)
    >>> figure = vadop.plot.cost_split(world.stats())          # one frame
    >>> frames = []
    >>> for _ in range(5):
    ...     _ = world.step(1 / 30)
    ...     frames.append(world.stats())
    >>> figure = vadop.plot.cost_split(frames)                 # five frames
    >>> len(figure.axes[0].patches)                            # a bar per stage and frame
    20
    """
    frames = [stats] if isinstance(stats, Mapping) else list(stats)
    if not frames:
        raise ValueError("stats must hold the stats of at least one frame")
    for k, frame in enumerate(frames):
        if not isinstance(frame, Mapping):
            raise TypeError(f"stats must be a World.stats() dict or a list of them, got {type(frame).__name__} at [{k}]")
        missing = [stage for stage in STAGES if stage not in frame]
        if missing:
            raise ValueError(f"stats[{k}] is not a World.stats() dict: it lacks {', '.join(missing)}")
    plt = _pyplot()
    figure, ax = (plt.subplots(figsize=(7, 3.5)) if ax is None else (ax.figure, ax))
    assert ax is not None
    numbers = np.arange(1, len(frames) + 1)
    bottom = np.zeros(len(frames))
    for stage in STAGES:
        ms = np.array([frame[stage] for frame in frames]) * 1e3
        ax.bar(numbers, ms, bottom=bottom, width=1.0, label=stage.replace("_seconds", ""))
        bottom += ms
    ax.set(xlabel="frame", ylabel="cost (ms)", title="c_total = c_update + c_sort + c_test + c_response")
    ax.legend(loc="upper right")
    return cast("Figure", figure)


def contact_timeline(
    contacts: Union[Contacts, Sequence[Contacts]],
    dt: Optional[float] = None,
    ax: Optional[Axes] = None,
) -> Figure:
    """Each contact as a dot at (time, body): body-body contacts at both bodies, wall contacts
    apart; with ``dt``, frame boundaries are marked and contacts per frame drawn underneath.

    ``contacts`` is one ``Contacts`` (a frame's, or ``vadop.detect``'s whole run) or a list of them.

    >>> import vadop, vadop.plot
    >>> world = vadop.scene(300, 0.1, 2.0)
    >>> figure = vadop.plot.contact_timeline([world.step(1 / 30) for _ in range(5)], dt=1 / 30)
    >>> len(figure.axes)
    2
    """
    frames = [contacts] if isinstance(contacts, Contacts) else list(contacts)
    time = np.concatenate([c.time for c in frames]) if frames else np.zeros(0)
    i = np.concatenate([c.i for c in frames]) if frames else np.zeros(0, dtype=np.int64)
    j = np.concatenate([c.j for c in frames]) if frames else np.zeros(0, dtype=np.int64)
    plt = _pyplot()
    if ax is None:
        rows = 2 if dt else 1
        figure, axes = plt.subplots(rows, 1, figsize=(8, 4.5 if dt else 3.5), sharex=True, squeeze=False,
                                    gridspec_kw={"height_ratios": [3, 1][:rows]})
        ax, counts_ax = axes[0][0], (axes[1][0] if dt else None)
    else:
        figure, counts_ax = ax.figure, None
    pair = j >= 0
    ax.scatter(np.concatenate([time[pair], time[pair]]), np.concatenate([i[pair], j[pair]]), s=6, label="body-body")
    ax.scatter(time[~pair], i[~pair], s=6, marker="x", label="wall")
    ax.set(ylabel="body", title=f"{len(time)} contacts ({int(pair.sum())} body-body)")
    ax.legend(loc="upper right")
    if dt and len(time):
        edges = np.arange(0.0, time.max() + dt, dt)
        if len(edges) < 200:
            for edge in edges:
                ax.axvline(edge, color="0.85", linewidth=0.5, zorder=0)
        if counts_ax is not None:
            counts, _ = np.histogram(time, bins=np.append(edges, edges[-1] + dt))
            counts_ax.bar(edges + dt / 2, counts, width=dt * 0.9)
            counts_ax.set(xlabel="time (s)", ylabel="per frame")
    else:
        ax.set_xlabel("time (s)")
    return cast("Figure", figure)
