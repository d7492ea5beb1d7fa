"""What accuracy costs: the data model, plots and page of `snapo bench accuracy`.

A domain contributes `AccuracyStudy`s (registered with `CommandLine.accuracy`); each holds
`Panel`s, one plot each: points `(x, y)` grouped into lines by `method`, typically wall time
after compile [s] against relative error, one line per solver or adjoint, the points along a
line its settings (tolerances, checkpoint counts, path counts). Where a panel states a `target`
error, the page lists, for each method, its cheapest setting that reaches it, so "what does 1e-6
cost with each solver" is read off a table, not a plot.

`write_accuracy` publishes, as one set: `OUT/accuracy.md` (the page), `OUT/accuracy/PANEL.png`
and `OUT/accuracy/PANEL.csv` for each panel, and `OUT/bench_accuracy.json` (every point) last.
The JSON holds all the page is made of: `read_accuracy` gives the studies back, so studies run
apart (one process each) are published as one page.
"""

import io
import json
import math
import pathlib
from collections.abc import Callable, Mapping, Sequence
from typing import NamedTuple

from .._platform.files import json_bytes, publish
from .._ode import SolverFailed, call_checked
from .results import jsonable
from .tables import Column, format_table, records_csv
from .._timing import time_function


class Point(NamedTuple):
    """One measurement: `method` names the line, `setting` what was set along it ("rtol=1e-06");
    `x` and `y` are the plotted values (units in the panel's labels); `extra` any other columns
    (compile seconds, steps, memory), written to the CSV and JSON. A setting that failed (max
    steps, a non-finite result) is a point with `failure` saying why and no `x`, `y` (NaN): it is
    listed under the panel, never plotted."""

    method: str
    setting: str
    x: float
    y: float
    extra: Mapping = {}
    failure: str = ""


class Panel(NamedTuple):
    """One plot and its table. `name` is the file stem (letters, digits, `_`, `-`); `target`, when
    given, is the `y` at or below which a point reaches the stated accuracy (the table then gives
    each method's cheapest such point: the smallest `x`); `notes` is Markdown shown under it."""

    name: str
    title: str
    x_label: str
    y_label: str
    points: Sequence[Point]
    target: float | None = None
    log_x: bool = True
    log_y: bool = True
    notes: str = ""


class AccuracyStudy(NamedTuple):
    """A section of the page: a `title`, Markdown `text` (problem, reference, conclusions) and its
    panels."""

    name: str
    title: str
    panels: Sequence[Panel]
    text: str = ""


def timed_point(method: str, setting: str, fn: Callable, argument, error_of: Callable, repeats: int) -> Point:
    """A point measured: `fn(argument)` (a jitted function whose failed solve leaves non-finite
    marks) through `call_checked`, timed (`time_function`: x is the median after compile, the
    compile time in `extra`), y = `error_of(output)`; a `SolverFailed` is a failure point."""
    try:
        timing, output = time_function(lambda x: call_checked(fn, x, what=method), argument, repeats=repeats)
    except SolverFailed:
        return Point(method, setting, math.nan, math.nan, failure="SolverFailed: max steps or a step-size collapse")
    return Point(method, setting, timing.median_seconds, error_of(output), {"compile_seconds": timing.compile_seconds})


def cheapest(panel: Panel) -> list[Point]:
    """For each method of `panel`, its point of smallest `x` with `y <= panel.target`, sorted by
    `x` (methods that never reach the target are left out); [] without a target."""
    if panel.target is None:
        return []
    best: dict[str, Point] = {}
    for point in panel.points:
        if not point.failure and math.isfinite(point.y) and point.y <= panel.target:
            if point.method not in best or point.x < best[point.method].x:
                best[point.method] = point
    return sorted(best.values(), key=lambda point: point.x)


def missed(panel: Panel) -> list[str]:
    """The methods of `panel` with no point at or below its target."""
    reached = {point.method for point in cheapest(panel)}
    return [method for method in dict.fromkeys(p.method for p in panel.points) if method not in reached] \
        if panel.target is not None else []


def panel_rows(panel: Panel) -> list[dict]:
    """The panel's points as rows (method, setting, x, y, the extras, and the failure if any;
    a non-finite x or y as empty)."""
    return [{"method": p.method, "setting": p.setting, "x": _finite_or_none(p.x), "y": _finite_or_none(p.y),
             **p.extra, "failure": p.failure} for p in panel.points]


def _finite_or_none(value: float) -> float | None:
    return value if math.isfinite(value) else None


def plot_png(panel: Panel) -> bytes:
    """The panel as a PNG: one line (with markers) per method, in the order methods first appear,
    each point labelled with its setting; the target as a dashed line."""
    import matplotlib
    import matplotlib.ticker

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7.0, 4.6), dpi=110)
    for method in dict.fromkeys(p.method for p in panel.points):
        line = sorted((p for p in panel.points if p.method == method and _plottable(p, panel)), key=lambda p: p.x)
        if not line:
            continue
        axes.plot([p.x for p in line], [p.y for p in line], marker="o", markersize=4, label=method)
    if panel.target is not None:
        axes.axhline(panel.target, color="black", linestyle="--", linewidth=0.8, label=f"target {panel.target:g}")
    axes.set_xscale("log" if panel.log_x else "linear")
    axes.set_yscale("log" if panel.log_y else "linear")
    axes.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # decades only: no overlapping labels
    axes.set_xlabel(panel.x_label)
    axes.set_ylabel(panel.y_label)
    axes.set_title(panel.title, fontsize=10)
    axes.grid(True, which="major", alpha=0.3)
    axes.legend(fontsize=7, loc="best")
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None})
    plt.close(figure)
    return buffer.getvalue()


def _plottable(point: Point, panel: Panel) -> bool:
    return (not point.failure and math.isfinite(point.x) and math.isfinite(point.y)
            and (not panel.log_x or point.x > 0) and (not panel.log_y or point.y > 0))


def markdown(studies: Sequence[AccuracyStudy], command: str, images: str = "accuracy") -> str:
    """The page: each study's text, and per panel its plot (from `images/`), its cheapest-setting
    table and notes."""
    lines = ["# What accuracy costs",
             "",
             f"Generated by `{command}`; every figure below is in `{images}/PANEL.csv` and "
             "`bench_accuracy.json`. Wall times are medians after JIT warm-up (compile reported apart), "
             "on the machine that ran the command.",
             ""]
    for study in studies:
        lines += [f"## {study.title}", ""]
        if study.text:
            lines += [study.text.strip(), ""]
        for panel in study.panels:
            lines += [f"### {panel.title}", "", f"![{panel.title}]({images}/{panel.name}.png)", ""]
            best = cheapest(panel)
            if panel.target is not None:
                lines += [f"Cheapest setting of each method reaching {panel.y_label} <= {panel.target:g}:", ""]
                if best:
                    lines += [format_table(
                        [{"method": p.method, "setting": p.setting, "x": p.x, "y": p.y} for p in best],
                        [Column("method", "method"), Column("setting", "setting"),
                         Column(panel.x_label, "x", ".3g"), Column(panel.y_label, "y", ".2g")]), ""]
                if missed(panel):
                    lines += ["Never reached: " + ", ".join(missed(panel)) + ".", ""]
            failures = [f"{p.method} at {p.setting}: {p.failure}" for p in panel.points if p.failure]
            if failures:
                lines += ["Failed: " + "; ".join(failures) + ".", ""]
            if panel.notes:
                lines += [panel.notes.strip(), ""]
    return "\n".join(lines)


def write_accuracy(out: str | pathlib.Path, studies: Sequence[AccuracyStudy], command: str,
                   extra: Mapping | None = None, json_path: str | pathlib.Path | None = None) -> list[pathlib.Path]:
    """Publish the page, each panel's PNG and CSV, and the JSON of every point (`json_path`,
    default `out/bench_accuracy.json`, written last) under `out`; returns the paths written."""
    out = pathlib.Path(out)
    files: dict[pathlib.Path, bytes] = {}
    for study in studies:
        for panel in study.panels:
            files[out / "accuracy" / f"{panel.name}.png"] = plot_png(panel)
            files[out / "accuracy" / f"{panel.name}.csv"] = records_csv(panel_rows(panel))
    files[out / "accuracy.md"] = markdown(studies, command).encode("utf-8")
    payload = {"command": command, **(extra or {}), "studies": [
        {"name": s.name, "title": s.title, "text": s.text, "panels": [
            {"name": p.name, "title": p.title, "x_label": p.x_label, "y_label": p.y_label, "target": p.target,
             "log_x": p.log_x, "log_y": p.log_y, "notes": p.notes,
             "rows": panel_rows(p), "cheapest": [c._asdict() for c in cheapest(p)], "missed": missed(p)}
            for p in s.panels]} for s in studies]}
    files[pathlib.Path(json_path) if json_path else out / "bench_accuracy.json"] = json_bytes(jsonable(payload))
    return publish(files)


_ROW_FIELDS = ("method", "setting", "x", "y", "failure")


def read_accuracy(json_path: str | pathlib.Path) -> list[AccuracyStudy]:
    """The studies of a `bench_accuracy.json` written by `write_accuracy` (a missing x or y is
    NaN; a row's other columns are its point's `extra`)."""
    payload = json.loads(pathlib.Path(json_path).read_text())

    def point(row: Mapping) -> Point:
        return Point(row["method"], row["setting"], math.nan if row["x"] is None else row["x"],
                     math.nan if row["y"] is None else row["y"],
                     {key: value for key, value in row.items() if key not in _ROW_FIELDS}, row["failure"])

    return [AccuracyStudy(study["name"], study["title"], [
        Panel(panel["name"], panel["title"], panel["x_label"], panel["y_label"], [point(row) for row in panel["rows"]],
              panel["target"], panel["log_x"], panel["log_y"], panel["notes"]) for panel in study["panels"]],
        study["text"]) for study in payload["studies"]]
