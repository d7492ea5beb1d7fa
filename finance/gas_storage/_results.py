"""The typed results of the storage studies: `StorageStudy` (`run_study`) and `LSMCComparison`
(`compare_with_lsmc`). Their JSON keys are those documented in docs/gas_storage.md; what later
steps need but a JSON file should not hold (the trained policy, the evaluation shocks, the hard
schedule of every path) travels with the result, outside the JSON."""

import dataclasses
from typing import ClassVar

import equinox as eqx
import jax
import numpy as np

from snapo_ode import BumpComparison, Result, Scene, field

from ._inputs import StorageInputs
from ._lp import IntrinsicSolution
from ._model import Schedule


def standard_error(values) -> float:
    """std / sqrt(n) of a sample (0 for fewer than two values)."""
    values = np.asarray(values)
    return float(np.std(values, ddof=1) / np.sqrt(values.size)) if values.size > 1 else 0.0


@dataclasses.dataclass(frozen=True, kw_only=True)
class StorageStudy(Result):
    """One storage study: the policy trained smooth, evaluated hard, next to the intrinsic LP, with
    every sensitivity from one reverse pass.

    Values [$]; flows and inventory [MMBtu] (or the units of the inputs). Stochastic fields
    (`paths` ... `schedule_note`) are None in deterministic mode, the bump fields without
    `--bump`; None fields are left out of the JSON."""

    mode: str
    scene: list
    value_hard: float
    value_smooth: float
    smoothing_gap: float
    intrinsic_lp: float
    intrinsic_method: str
    hard_to_lp_ratio: float | None
    max_constraint_violation: float
    capacity: float
    schedule: dict
    deltas: list
    lp_envelope_deltas: list
    parameter_sensitivities: dict
    train_seconds: float
    train_wall_seconds: float
    train_steps: int
    compile_seconds: float
    compile_breakdown: dict
    forward_seconds: float
    gradient_seconds: float
    gradient_forward_ratio: float
    training_history: dict
    training_curve: list
    head: str
    training_settings: dict
    start: str = "intrinsic"
    start_seconds: float = 0.0
    start_value_hard: float | None = None
    paths: int | None = None
    train_paths: int | None = None
    seed: int | None = None
    value_hard_se: float | None = None
    value_smooth_se: float | None = None
    evaluation: str | None = None
    schedule_note: str | None = None
    policy: eqx.Module = field(json=False)
    inputs: StorageInputs = field(json=False)
    scene_effects: Scene = field(json=False)
    evaluation_shocks: jax.Array | None = field(json=False)
    hard: Schedule = field(json=False)
    intrinsic: IntrinsicSolution = field(json=False)
    bump: BumpComparison | None = field(json=False, default=None)
    bump_relative_step: float | None = None
    omit_none: ClassVar[bool] = True

    def bump_fields(self) -> dict:
        """The central bump-and-revalue figures of the 365 deltas (empty without bumps)."""
        if self.bump is None:
            return {}
        normwise = self.bump.agreement.normwise
        return {
            "bump_batched_seconds": self.bump.bump_seconds,
            "bump_sequential_seconds": self.bump.sequential_seconds,
            "bump_seconds": min(self.bump.bump_seconds, self.bump.sequential_seconds),
            "bump_compile_seconds": self.bump.bump_compile_seconds,
            # Per day, days below 1e-3 of the largest delta compared at that scale (a central
            # difference cannot resolve them further); normwise: largest difference over largest delta.
            "max_rel_diff": self.bump.max_rel_diff,
            "max_diff_over_max_delta": normwise,
            "bump_relative_step": self.bump_relative_step,
        }

    def to_json(self) -> dict:
        # hard_to_lp_ratio is always present: null when the LP is worth nothing.
        return {**super().to_json(), "hard_to_lp_ratio": self.hard_to_lp_ratio, **self.bump_fields()}

    def summary(self) -> str:
        days = len(self.deltas)
        lines = [
            f"gas storage, {self.mode} ({days} days)",
            f"  intrinsic value (exact {self.intrinsic_method})   {self.intrinsic_lp:>16,.0f} $",
            f"  policy value, hard constraints      {self.value_hard:>16,.0f} $"
            + (f"   ({100 * self.hard_to_lp_ratio:.2f}% of intrinsic)" if self.hard_to_lp_ratio is not None else ""),
            f"  policy value, smooth (training)     {self.value_smooth:>16,.0f} $"
            f"   (smooth - hard: {self.smoothing_gap:,.0f} $)",
            f"  worst hard-constraint violation     {self.max_constraint_violation:>16.2e} MMBtu",
            f"  training: {self.train_steps} steps in {self.train_seconds:.1f} s after "
            f"{self.compile_seconds:.1f} s compile"
            + ("" if self.start_value_hard is None else
               f"; started on the lattice's targets ({self.start_seconds:.1f} s, worth {self.start_value_hard:,.0f} $ "
               f"untrained)"),
            f"  {days} forward-curve deltas + {len(self.parameter_sensitivities)} parameter sensitivities from one "
            f"reverse pass: {1e3 * self.gradient_seconds:.2f} ms ({self.gradient_forward_ratio:.2f}x the forward pass)",
        ]
        if self.value_hard_se is not None:
            lines.insert(3, f"  standard error (out of sample)      {self.value_hard_se:>16,.0f} $")
        if self.bump is not None:
            fields = self.bump_fields()
            lines.append(f"  central bump-and-revalue: batched {1e3 * fields['bump_batched_seconds']:.1f} ms, sequential "
                         f"{1e3 * fields['bump_sequential_seconds']:.0f} ms; max relative difference "
                         f"{fields['max_rel_diff']:.1e}")
        return "\n".join(lines)


@dataclasses.dataclass(frozen=True, kw_only=True)
class LSMCComparison(Result):
    """SNAPO against least-squares Monte Carlo on the same contract and the same fresh paths:
    the SNAPO `study` (its JSON fields stay at the top level of this one's JSON), both
    out-of-sample values with the hard constraints, their paired difference, the
    perfect-foresight bound, the dual upper bound with each policy's duality gap (and the factor
    lattice's near-optimal rule as a reference, at non-zero volatility), LSMC's pathwise deltas,
    and the wall time of each method (`_certificate.py`); `warnings`: what a reader must
    know before trusting a figure (a bound that failed a check, a policy below the intrinsic
    value), also printed on stderr. Values [$]; gaps as fractions of the
    bound; `deltas_snapo_vs_lsmc`: the largest difference of the two methods' daily deltas over the
    largest LSMC delta."""

    study: StorageStudy = field(json=False)
    lsmc_in_sample: float
    lsmc_in_sample_se: float
    lsmc_out_of_sample: float
    lsmc_se: float
    lsmc_fit_seconds: float
    lsmc_eval_seconds: float
    lsmc_compile_seconds: float
    lsmc_nodes: int
    lsmc_degree: int
    snapo_out_of_sample: float
    snapo_se: float
    snapo_minus_lsmc: float
    snapo_minus_lsmc_se: float
    perfect_foresight: float
    perfect_foresight_se: float
    perfect_foresight_paths: int
    snapo_seconds: float
    lsmc_inventory_mean: list
    dual_upper_bound: float | None
    dual_upper_bound_se: float | None
    dual_penalty: str
    dual_bounds_continuous_policies: bool
    dual_grid_nodes: int
    dual_grid_spacing: float  # [MMBtu]
    dual_grid_first_level: float  # [MMBtu], in (-spacing, 0]: below 0 where the grid is anchored on the terminal requirement
    dual_relaxation: float
    dual_paths: int
    dual_seconds: float
    snapo_value_control_variate: float
    snapo_value_control_variate_se: float
    snapo_gap: float | None
    snapo_gap_se: float | None
    lsmc_value_control_variate: float
    lsmc_value_control_variate_se: float
    lsmc_gap: float | None
    lsmc_gap_se: float | None
    intrinsic_value_control_variate: float
    intrinsic_value_control_variate_se: float
    intrinsic_gap: float | None
    intrinsic_gap_se: float | None
    warnings: list
    lattice_out_of_sample: float | None = None
    lattice_se: float | None = None
    lattice_value_control_variate: float | None = None
    lattice_value_control_variate_se: float | None = None
    lattice_gap: float | None = None
    lattice_gap_se: float | None = None
    lsmc_pathwise_deltas: list
    lsmc_deltas_seconds: float
    lsmc_plus_deltas_seconds: float
    lsmc_plus_bumps_seconds: float
    deltas_snapo_vs_lsmc: float
    lsmc_schedule: Schedule = field(json=False)
    omit_none: ClassVar[bool] = True

    def to_json(self) -> dict:
        # The bound and the gaps are always present: null where the bound could not be certified.
        nullable = {key: getattr(self, key) for key in ("dual_upper_bound", "dual_upper_bound_se", "snapo_gap",
                                                         "snapo_gap_se", "lsmc_gap", "lsmc_gap_se")}
        return {**self.study.to_json(), **super().to_json(), **nullable}

    @staticmethod
    def _percent(gap: float | None, se: float | None) -> str:
        return "not certified" if gap is None else f"{100 * gap:.3f}% +- {100 * se:.3f}%"

    def summary(self) -> str:
        days = len(self.study.deltas)
        return "\n".join([
            self.study.summary(),
            f"  on the same {self.study.paths:,} fresh paths (out of sample, hard constraints):",
            f"    SNAPO policy                      {self.snapo_out_of_sample:>16,.0f} $ +- {self.snapo_se:,.0f}",
            f"    LSMC ({self.lsmc_nodes} nodes, degree {self.lsmc_degree})         "
            f"{self.lsmc_out_of_sample:>16,.0f} $ +- {self.lsmc_se:,.0f}   (in sample {self.lsmc_in_sample:,.0f})",
            f"    SNAPO - LSMC (paired)             {self.snapo_minus_lsmc:>16,.0f} $ +- {self.snapo_minus_lsmc_se:,.0f}",
            f"    perfect foresight ({self.perfect_foresight_paths} paths)     "
            f"{self.perfect_foresight:>16,.0f} $ +- {self.perfect_foresight_se:,.0f}",
            f"    dual upper bound ({self.dual_penalty}, {self.dual_grid_nodes} levels)   "
            + ("not certified" if self.dual_upper_bound is None else
               f"{self.dual_upper_bound:>16,.0f} $ +- {self.dual_upper_bound_se:,.0f}"),
            f"    duality gap: SNAPO {self._percent(self.snapo_gap, self.snapo_gap_se)}, LSMC "
            f"{self._percent(self.lsmc_gap, self.lsmc_gap_se)}"
            + ("" if self.lattice_gap is None else f", lattice rule {100 * self.lattice_gap:.3f}%")
            + (f" (rates relaxed by up to {self.dual_relaxation:.1%} to solve it on a grid)"
               if self.dual_relaxation > 0 else ""),
            f"  value + {days} deltas: SNAPO {self.snapo_seconds:.1f} s (training and one reverse pass); LSMC + pathwise "
            f"deltas {self.lsmc_plus_deltas_seconds:.1f} s; LSMC + bumps ~{self.lsmc_plus_bumps_seconds / 60:.0f} min "
            f"(estimated); compile apart",
            f"  SNAPO's deltas against LSMC's pathwise deltas: largest difference {self.deltas_snapo_vs_lsmc:.1%} of "
            "the largest",
        ] + [f"  warning: {warning}" for warning in self.warnings])
