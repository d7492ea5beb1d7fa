"""`snapo bench scaling`: strong and weak scaling of the domains' sample-parallel workloads over
device counts.

A domain registers a workload with `CommandLine.scaling(name, run)`: `run(args)` measures on
`args.mesh` (the samples mesh of this process's `--devices`, or None on one device) and returns
rows, each a dict with at least:

- `workload` (what is measured), `scaling` ("strong": a fixed total of samples; "weak": a fixed
  number per device), `devices`, `samples` (the total);
- `seconds` (median after compile), `compile_seconds`, `temp_megabytes_per_device` (XLA's
  temporary memory of the compiled program, per device);
- `collective_bytes`: what one call communicates between devices (an all-reduce's payload).

The device count of a process is fixed when JAX starts, so the bench runs each count in a `snapo`
process of its own and merges the rows here: `with_efficiency` adds each row's speed-up and
efficiency against one device (strong: t1 / (n t_n); weak: t1 / t_n).
"""

import io
from collections.abc import Sequence

from .tables import Column

COLUMNS = (
    Column("workload", "workload"), Column("scaling", "scaling"), Column("devices", "devices"),
    Column("samples", "samples", ",d"), Column("s (median)", "seconds", ".4g"),
    Column("speed-up", "speedup", ".2f"), Column("efficiency", "efficiency", ".0%"),
    Column("compile s", "compile_seconds", ".1f"), Column("temp MB / device", "temp_megabytes_per_device", ".1f"),
    Column("collective bytes", "collective_bytes", ",d"),
)


def with_efficiency(rows: Sequence[dict]) -> list[dict]:
    """`rows` with `speedup` (t1 / t_n for strong scaling, t1 n / t_n for weak: samples per
    second against one device) and `efficiency` (speed-up / n), each against the one-device row
    of the same workload and scaling (None without one)."""
    single = {(row["workload"], row["scaling"]): row["seconds"] for row in rows if row["devices"] == 1}
    out = []
    for row in rows:
        base = single.get((row["workload"], row["scaling"]))
        n = row["devices"]
        speedup = None if base is None else base / row["seconds"] * (n if row["scaling"] == "weak" else 1)
        out.append({**row, "speedup": speedup, "efficiency": None if speedup is None else speedup / n})
    return out


def scaling_png(rows: Sequence[dict]) -> bytes:
    """Efficiency against devices, one line per (workload, scaling), the ideal as a dashed line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=(7.0, 4.2), dpi=110)
    for key in dict.fromkeys((row["workload"], row["scaling"]) for row in rows):
        line = sorted((row for row in rows if (row["workload"], row["scaling"]) == key and row["efficiency"] is not None),
                      key=lambda row: row["devices"])
        axes.plot([row["devices"] for row in line], [row["efficiency"] for row in line], marker="o",
                  label=f"{key[0]}, {key[1]}")
    counts = sorted({row["devices"] for row in rows})
    axes.plot(counts, [1.0] * len(counts), "k--", linewidth=0.8, label="ideal")
    axes.set_xscale("log", base=2)
    axes.set_xticks(counts, [str(n) for n in counts])
    axes.set_xlabel("devices")
    axes.set_ylabel("parallel efficiency")
    axes.set_ylim(0, 1.2)
    axes.grid(True, alpha=0.3)
    axes.legend(fontsize=7)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", metadata={"Software": None})
    plt.close(figure)
    return buffer.getvalue()
