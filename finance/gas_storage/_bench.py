"""`snapo bench gas`: every figure of the storage headline, measured in one run."""

import csv
import io
import pathlib

import equinox as eqx
import jax
import jax.numpy as jnp

from snapo_ode import atomic_write_json, atomic_write_text, time_function

from ._cases import CASES
from ._cli import summary_table
from ._inputs import make_inputs, sample_curve, sample_facility
from ._model import deterministic_scene, make_policy, simulate_path
from ._study import StudySettings, run_study


def rollout_comparison(repeats: int) -> list[dict]:
    """Forward and gradient time of the 365-day deterministic model (smooth) rolled out by
    `lax.scan` and by Diffrax's `DiscreteStepper` (checkpoints = number of steps)."""
    inputs = make_inputs(sample_facility(), sample_curve())
    scene = deterministic_scene()
    policy = make_policy(scene, inputs, key=jax.random.key(0))
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
        result, _ = run_study(make_inputs(facility, curve), StudySettings(progress=False, repeats=repeats))
        rows.append({"case": name, "intrinsic_lp": result["intrinsic_lp"], "value_hard": result["value_hard"],
                     "hard_over_lp": result["hard_to_lp_ratio"], "smoothing_gap": result["smoothing_gap"],
                     "max_constraint_violation": result["max_constraint_violation"],
                     "train_seconds": result["train_seconds"]})
    return rows


def run_gas_benchmark(out: pathlib.Path, *, paths: int, repeats: int) -> int:
    """Run the deterministic and stochastic studies with bumps and the rollout comparison;
    print the table and write `bench_gas.json` and `bench_gas.csv` under `out`."""
    inputs = make_inputs(sample_facility(), sample_curve())
    # Millisecond timings on a shared machine: take the median of more runs.
    deterministic, _ = run_study(inputs, StudySettings(bump=True, repeats=max(repeats, 25)))
    print(summary_table(deterministic))
    stochastic_inputs = make_inputs(sample_facility(), sample_curve(), volatility=0.5, mean_reversion=2.0)
    stochastic, _ = run_study(stochastic_inputs, StudySettings(stochastic=True, paths=paths, bump=True,
                                                            repeats=repeats, train_steps=400))
    print(summary_table(stochastic))
    rollouts = rollout_comparison(max(repeats, 25))
    pairs = facility_pairs(1)
    rows = []
    for name, result in (("deterministic", deterministic), (f"stochastic, {paths} paths", stochastic)):
        rows.append({
            "case": name,
            "value_hard_over_lp": result["hard_to_lp_ratio"],
            "train_seconds": result["train_seconds"],
            "train_steps": result["train_steps"],
            "compile_seconds": result["compile_seconds"],
            "forward_ms": 1e3 * result["forward_seconds"],
            "gradient_ms": 1e3 * result["gradient_seconds"],
            "gradient_forward_ratio": result["gradient_forward_ratio"],
            "bump_batched_ms": 1e3 * result["bump_batched_seconds"],
            "bump_sequential_ms": 1e3 * result["bump_sequential_seconds"],
            "speedup_vs_batched": result["bump_batched_seconds"] / result["gradient_seconds"],
            "speedup_vs_sequential": result["bump_sequential_seconds"] / result["gradient_seconds"],
            "max_rel_diff": result["max_rel_diff"],
        })
    scan, diffrax = rollouts
    print("\ncase | hard/LP | train s (steps) | compile s | fwd ms | grad ms | grad/fwd | "
          "bump batched ms | bump sequential ms | speedup batched | speedup sequential | max rel diff")
    for row in rows:
        print(f"{row['case']} | {100 * row['value_hard_over_lp']:.2f}% | {row['train_seconds']:.1f} "
              f"({row['train_steps']}) | {row['compile_seconds']:.1f} | {row['forward_ms']:.2f} | "
              f"{row['gradient_ms']:.2f} | {row['gradient_forward_ratio']:.2f} | {row['bump_batched_ms']:.1f} | "
              f"{row['bump_sequential_ms']:.0f} | {row['speedup_vs_batched']:.0f}x | "
              f"{row['speedup_vs_sequential']:.0f}x | {row['max_rel_diff']:.1e}")
    print("\nrollout | forward ms | gradient ms | gradient/forward | compile s")
    for row in rollouts:
        print(f"{row['method']} | {1e3 * row['forward_seconds']:.2f} | {1e3 * row['gradient_seconds']:.2f} | "
              f"{row['gradient_forward_ratio']:.2f} | {row['compile_seconds']:.1f}")
    for kind in ("forward", "gradient"):
        ratio = diffrax[f"{kind}_seconds"] / scan[f"{kind}_seconds"]
        faster = "lax.scan" if ratio > 1 else "Diffrax"
        print(f"{kind}: {faster} is faster, by {max(ratio, 1 / ratio):.2f}x")
    print("\nfacility/curve | intrinsic LP $ | policy, hard $ | hard/LP | smooth - hard $ | worst violation | train s")
    for row in pairs:
        print(f"{row['case']} | {row['intrinsic_lp']:,.0f} | {row['value_hard']:,.0f} | {100 * row['hard_over_lp']:.2f}% | "
              f"{row['smoothing_gap']:,.0f} | {row['max_constraint_violation']:.1e} | {row['train_seconds']:.1f}")
    write_tables(out, "bench_gas", rows, {"studies": rows, "rollout": rollouts, "facility_pairs": pairs})
    return 0


def write_tables(out: pathlib.Path, name: str, rows: list[dict], everything: dict) -> None:
    """Write `rows` as `out/name.csv` and `everything` as `out/name.json`, atomically."""
    buffer = io.StringIO()
    writer = csv.DictWriter(buffer, fieldnames=list(rows[0]))
    writer.writeheader()
    writer.writerows(rows)
    atomic_write_text(out / f"{name}.csv", buffer.getvalue())
    atomic_write_json(out / f"{name}.json", everything)
    print(f"written: {out / (name + '.csv')}, {out / (name + '.json')}")
