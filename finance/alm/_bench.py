"""`snapo bench alm`: the scaling of sensitivity cost with the number of risk factors N, the
adjoint against batched central bump-and-revalue and batched forward mode, same paths and
horizon at every N, measured side by side in one run."""

import io
import pathlib

import jax
import jax.numpy as jnp
from tqdm.auto import tqdm

from snapo_ode import Column, check_count, write_table
from snapo_ode import format_table as markdown_table

from ._factors import layout_for
from ._policy import NeuralRebalancing
from ._scenarios import on_devices
from ._memory import check_size
from ._study import measure_sensitivities, scenarios, study_for

DEFAULT_COUNTS = (10, 50, 100, 500, 1000, 2000)
COLUMNS = (
    Column("N", "n_risk_factors"), Column("adjoint (one reverse pass) s", "adjoint_seconds", ".4f"),
    Column("value alone s", "value_seconds", ".4f"), Column("grad/fwd", "gradient_forward_ratio", ".2f"),
    Column("central bump, batched (2N+1 runs) s", "bump_seconds", ".3f"),
    Column("forward mode (N tangents) s", "forward_mode_seconds", ".3f"),
    Column("speedup over bump", "speedup", lambda v: f"{v:.0f}x"),
    Column("target N/4", "target_speedup", lambda v: f"{v:.1f}x"), Column("adjoint vs bump", "max_rel_diff", ".1e"),
)


def scaling_rows(counts=DEFAULT_COUNTS, *, n_paths: int = 128, horizon_months: int | None = None,
                 repeats: int = 3, seed: int = 0, progress: bool = True, mesh=None, fund=None,
                 scenario_set=None) -> list[dict]:
    """One row per N in `counts` (120 months unless `horizon_months`), or one row for `fund`
    (`load_fund`; over its horizon unless `horizon_months`, on its `scenario_set` where given:
    `load_scenarios`, every scenario a path): median seconds of the three methods
    (bump and forward mode run once after the first call when N > 100, `repeats` times
    otherwise), the speedup of the adjoint over the bump, its target N/4, and the largest
    relative differences. `mesh`: the devices the paths split over."""
    check_count("paths", n_paths)
    check_count("repeats", repeats)
    if fund is None:
        for n in counts:
            check_size(layout_for(n), 120 if horizon_months is None else horizon_months, n_paths)
    rows = []
    for n in tqdm((None,) if fund is not None else counts, desc="bench alm", disable=not progress):
        study = study_for(n, fund, horizon_months, scenario_set)
        key = jax.random.key(seed)
        shocks = (scenarios(study, n_paths, jax.random.fold_in(key, 2), mesh) if scenario_set is None
                  else on_devices(jnp.asarray(scenario_set.values), mesh))
        policy = NeuralRebalancing(study.market, key=jax.random.fold_in(key, 1))
        layout = study.layout
        measured = measure_sensitivities(study, policy, shocks, repeats=repeats,
                                         baseline_repeats=repeats if layout.n_risk_factors <= 100 else 1)
        rows.append(dict(
            n_risk_factors=layout.n_risk_factors, n_tenors=layout.n_tenors, n_equities=layout.n_equities,
            n_liability=layout.n_liability, adjoint_seconds=measured.adjoint_seconds,
            value_seconds=measured.value_seconds, gradient_forward_ratio=measured.gradient_forward_ratio,
            bump_seconds=measured.bump_seconds, forward_mode_seconds=measured.forward_mode_seconds,
            speedup=measured.speedup, target_speedup=layout.n_risk_factors / 4,
            forward_mode_speedup=measured.forward_mode_speedup, max_rel_diff=measured.max_rel_diff,
            max_rel_diff_forward_mode=measured.max_rel_diff_forward_mode,
            **{f"{method}_compile_seconds": seconds for method, seconds in measured.compile_seconds.items()},
        ))
    return rows


def format_table(rows: list[dict]) -> str:
    """A Markdown table of the main columns."""
    return markdown_table(rows, COLUMNS)


def write_scaling(rows: list[dict], out_dir) -> list[pathlib.Path]:
    """Write `bench_alm.csv` and `bench_alm.json` (every bench's names), `alm_scaling.png`, and the
    same table under its first names `alm_scaling.csv` and `alm_scaling.json`, into `out_dir`, one set."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
    return write_table(out_dir, "bench_alm", rows, files={"alm_scaling.png": image.getvalue()}, also_as=("alm_scaling",))
