"""`snapo bench gas`: every figure of the storage headline, measured in one run."""

import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import Column, format_table, time_function, write_table

from ._cases import CASES
from ._files import sample_curve, sample_facility
from ._inputs import make_inputs
from ._action_heads import make_action_policy, simulate_path
from ._model import deterministic_scene
from ._study import StudySettings, run_study

STUDY_COLUMNS = (
    Column("case", "case"), Column("hard / LP", "value_hard_over_lp", lambda v: f"{100 * v:.2f}%"),
    Column("train s", "train_seconds", ".1f"), Column("steps", "train_steps"),
    Column("compile s", "compile_seconds", ".1f"), Column("forward ms", "forward_ms", ".2f"),
    Column("gradient ms (all inputs + policy)", "gradient_ms", ".2f"), Column("grad/fwd", "gradient_forward_ratio", ".2f"),
    Column("365 bumps, batched ms", "bump_batched_ms", ".1f"), Column("365 bumps, sequential ms", "bump_sequential_ms", ".0f"),
    Column("speedup vs batched", "speedup_vs_batched", lambda v: f"{v:.2g}x"),
    Column("vs sequential", "speedup_vs_sequential", lambda v: f"{v:.3g}x"),
    Column("adjoint vs bumps", "max_rel_diff", ".1e"),
)
ROLLOUT_COLUMNS = (
    Column("rollout", "method"), Column("forward ms", "forward_seconds", lambda v: f"{1e3 * v:.2f}"),
    Column("gradient ms", "gradient_seconds", lambda v: f"{1e3 * v:.2f}"),
    Column("gradient/forward", "gradient_forward_ratio", ".2f"), Column("compile s", "compile_seconds", ".1f"),
)
PAIR_COLUMNS = (
    Column("facility / curve", "case"), Column("intrinsic LP $", "intrinsic_lp", ",.0f"),
    Column("policy, hard $", "value_hard", ",.0f"), Column("hard / LP", "hard_over_lp", lambda v: f"{100 * v:.2f}%"),
    Column("smooth - hard $", "smoothing_gap", ",.0f"), Column("worst violation", "max_constraint_violation", ".1e"),
    Column("train s", "train_seconds", ".1f"),
)


def rollout_comparison(repeats: int) -> list[dict]:
    """Forward and gradient time of the 365-day deterministic model (smooth) rolled out by
    `lax.scan` and by Diffrax's `DiscreteStepper` (checkpoints = number of steps)."""
    inputs = make_inputs(sample_facility(), sample_curve())
    scene = deterministic_scene()
    policy = make_action_policy(scene, inputs, key=jax.random.key(0))
    zeros = jnp.zeros(inputs.n_days)
    rows = []
    for method in ("scan", "diffrax"):
        def value(policy, inputs, method=method):
            return simulate_path(policy, inputs, scene, inputs.forward_curve, zeros, sharpness=200.0,
                                 method=method).value

        forward, _ = time_function(eqx.filter_jit(value), policy, inputs, repeats=repeats)
        gradient, _ = time_function(eqx.filter_jit(eqx.filter_grad(value)), policy, inputs, repeats=repeats)
        rows.append({"method": method, "forward_seconds": forward.median_seconds,
                     "gradient_seconds": gradient.median_seconds,
                     "gradient_forward_ratio": gradient.median_seconds / forward.median_seconds,
                     "compile_seconds": forward.compile_seconds + gradient.compile_seconds})
    return rows


def facility_pairs(repeats: int) -> list[dict]:
    """The hard-evaluated policy value against the intrinsic LP on every built-in pair."""
    rows = []
    for name, case in CASES.items():
        facility, curve = case()
        study = run_study(make_inputs(facility, curve), StudySettings(progress=False, repeats=repeats))
        rows.append({"case": name, "intrinsic_lp": study.intrinsic_lp, "value_hard": study.value_hard,
                     "hard_over_lp": study.hard_to_lp_ratio, "smoothing_gap": study.smoothing_gap,
                     "max_constraint_violation": study.max_constraint_violation,
                     "train_seconds": study.train_seconds})
    return rows


def study_row(name: str, study) -> dict:
    """The headline figures of one study with bumps."""
    fields = study.bump_fields()
    return {
        "case": name, "value_hard_over_lp": study.hard_to_lp_ratio, "train_seconds": study.train_seconds,
        "train_steps": study.train_steps, "compile_seconds": study.compile_seconds,
        "forward_ms": 1e3 * study.forward_seconds, "gradient_ms": 1e3 * study.gradient_seconds,
        "gradient_forward_ratio": study.gradient_forward_ratio,
        "bump_batched_ms": 1e3 * fields["bump_batched_seconds"],
        "bump_sequential_ms": 1e3 * fields["bump_sequential_seconds"],
        "speedup_vs_batched": fields["bump_batched_seconds"] / study.gradient_seconds,
        "speedup_vs_sequential": fields["bump_sequential_seconds"] / study.gradient_seconds,
        "max_rel_diff": fields["max_rel_diff"],
    }


def run_gas_benchmark(out: pathlib.Path, *, paths: int, repeats: int) -> int:
    """Run the deterministic and stochastic studies with bumps and the rollout comparison;
    print the tables and write `bench_gas.json` and `bench_gas.csv` under `out`."""
    inputs = make_inputs(sample_facility(), sample_curve())
    # Millisecond timings on a shared machine: take the median of more runs.
    deterministic = run_study(inputs, StudySettings(bump=True, repeats=max(repeats, 25)))
    print(deterministic.summary())
    stochastic_inputs = make_inputs(sample_facility(), sample_curve(), volatility=0.5, mean_reversion=2.0)
    stochastic = run_study(stochastic_inputs, StudySettings(stochastic=True, paths=paths, bump=True, repeats=repeats,
                                                            train_steps=400))
    print(stochastic.summary())
    rollouts = rollout_comparison(max(repeats, 25))
    pairs = facility_pairs(1)
    rows = [study_row("deterministic", deterministic), study_row(f"stochastic, {paths} paths", stochastic)]
    print(format_table(rows, STUDY_COLUMNS))
    print(format_table(rollouts, ROLLOUT_COLUMNS))
    scan, diffrax = rollouts
    for kind in ("forward", "gradient"):
        ratio = diffrax[f"{kind}_seconds"] / scan[f"{kind}_seconds"]
        faster = "lax.scan" if ratio > 1 else "Diffrax"
        print(f"{kind}: {faster} is faster, by {max(ratio, 1 / ratio):.2f}x")
    print(format_table(pairs, PAIR_COLUMNS))
    paths_written = write_table(out, "bench_gas", rows, {"rollout": rollouts, "facility_pairs": pairs})
    print(f"written: {', '.join(map(str, paths_written))}")
    return 0
