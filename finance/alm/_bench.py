"""`snapo bench alm`: the scaling of sensitivity cost with the number of risk factors N, the
adjoint against batched central bump-and-revalue and batched forward mode, same paths and
horizon at every N, measured side by side in one run."""

import csv
import io
import pathlib

import jax
from tqdm.auto import tqdm

from snapo_ode import atomic_write_bytes, atomic_write_text

from ._factors import layout_for
from ._policy import NeuralRebalancing
from ._study import build_study, check_count, measure_sensitivities, scenarios

DEFAULT_COUNTS = (10, 50, 100, 500, 1000, 2000)
COLUMNS = (
    "n_risk_factors", "n_tenors", "n_equities", "n_liability", "adjoint_seconds", "bump_seconds",
    "forward_mode_seconds", "speedup", "target_speedup", "forward_mode_speedup", "max_rel_diff",
    "max_rel_diff_forward_mode", "adjoint_compile_seconds", "bump_compile_seconds",
    "forward_mode_compile_seconds",
)


def scaling_rows(counts=DEFAULT_COUNTS, *, n_paths: int = 128, horizon_months: int = 120,
                 repeats: int = 3, seed: int = 0, progress: bool = True) -> list[dict]:
    """One row per N in `counts`: median seconds of the three methods (bump and forward mode
    run once after compiling when N > 100, `repeats` times otherwise), the speedup of the
    adjoint over the bump, its target N/4, and the largest relative differences."""
    for n in counts:
        layout_for(n)
    check_count("paths", n_paths)
    check_count("repeats", repeats)
    rows = []
    for n in tqdm(counts, desc="bench alm", disable=not progress):
        study = build_study(n, horizon_months=horizon_months)
        key = jax.random.key(seed)
        shocks = scenarios(study, n_paths, jax.random.fold_in(key, 2))
        policy = NeuralRebalancing(study.market, key=jax.random.fold_in(key, 1))
        measured = measure_sensitivities(study, policy, shocks, repeats=repeats,
                                         baseline_repeats=repeats if n <= 100 else 1)
        layout = study.layout
        compile_seconds = measured["compile_seconds"]
        rows.append(dict(
            n_risk_factors=layout.n_risk_factors, n_tenors=layout.n_tenors,
            n_equities=layout.n_equities, n_liability=layout.n_liability,
            target_speedup=layout.n_risk_factors / 4,
            adjoint_compile_seconds=compile_seconds["adjoint"],
            bump_compile_seconds=compile_seconds["bump"],
            forward_mode_compile_seconds=compile_seconds["forward_mode"],
            **{k: measured[k] for k in COLUMNS if k in measured},
        ))
    return rows


def format_table(rows: list[dict]) -> str:
    """A Markdown table of the main columns."""
    lines = ["| N | adjoint [s] | bump [s] | forward mode [s] | speedup | target N/4 | max rel diff |",
             "| ---: | ---: | ---: | ---: | ---: | ---: | ---: |"]
    for row in rows:
        lines.append(
            f"| {row['n_risk_factors']} | {row['adjoint_seconds']:.4f} | {row['bump_seconds']:.3f} "
            f"| {row['forward_mode_seconds']:.3f} | {row['speedup']:.0f}x | "
            f"{row['target_speedup']:.1f}x | {row['max_rel_diff']:.1e} |")
    return "\n".join(lines)


def write_scaling(rows: list[dict], out_dir) -> tuple[pathlib.Path, pathlib.Path]:
    """Write `alm_scaling.csv` and `alm_scaling.png` into `out_dir`, atomically."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = pathlib.Path(out_dir)
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=COLUMNS)
    writer.writeheader()
    writer.writerows(rows)
    csv_path = atomic_write_text(out_dir / "alm_scaling.csv", buffer.getvalue())

    counts = [row["n_risk_factors"] for row in rows]
    figure, (left, right) = plt.subplots(1, 2, figsize=(10, 4))
    for label, column in (("adjoint (one reverse pass)", "adjoint_seconds"),
                          ("central bump-and-revalue", "bump_seconds"),
                          ("forward mode", "forward_mode_seconds")):
        left.loglog(counts, [row[column] for row in rows], "o-", label=label)
    left.set_xlabel("risk factors N")
    left.set_ylabel("seconds (median)")
    left.legend()
    right.loglog(counts, [row["speedup"] for row in rows], "o-", label="bump / adjoint")
    right.loglog(counts, [row["target_speedup"] for row in rows], "--", label="target N/4")
    right.set_xlabel("risk factors N")
    right.set_ylabel("speedup")
    right.legend()
    figure.tight_layout()
    image = io.BytesIO()
    figure.savefig(image, format="png", dpi=120)
    plt.close(figure)
    png_path = atomic_write_bytes(out_dir / "alm_scaling.png", image.getvalue())
    return csv_path, png_path
