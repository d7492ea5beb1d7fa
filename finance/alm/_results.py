"""The typed results of the ALM studies: a policy's `Evaluation` on a set of paths, the
`SensitivityMeasurement` of the objective's sensitivities (adjoint, and the batched baselines
beside it), and the `ALMStudy` of `snapo alm`, whose JSON keys are documented in docs/alm.md."""

import dataclasses

import jax
import numpy as np

from snapo_ode import BumpComparison, Result, field, to_host

from ._policy import AbstractRebalancing


@dataclasses.dataclass(frozen=True, kw_only=True)
class Evaluation(Result):
    """A policy on a set of paths: the `objective` with the exact constraints, with the smooth
    surrogates (`objective_smooth`) and their `smoothing_gap`, the funding-ratio statistics at the
    horizon (exact) and the `mean_surplus`."""

    objective: float
    objective_smooth: float
    smoothing_gap: float
    funding_ratio: dict
    mean_surplus: float

    def summary(self) -> str:
        ratio = self.funding_ratio
        return (f"objective {self.objective:.6f} (smooth {self.objective_smooth:.6f}); funding ratio mean "
                f"{ratio['mean']:.3f}, 5% {ratio['p05']:.3f}, P(< 1) {ratio['probability_below_1']:.4f}")


@dataclasses.dataclass(frozen=True, kw_only=True)
class SensitivityMeasurement(Result):
    """The smooth objective's sensitivities to every reported factor from one reverse pass
    (`sensitivities`, name -> value; `gradient`, the pytree), and with the baselines the same by
    batched central bump-and-revalue and batched forward mode on the same paths, timed side by
    side (medians after a first call; `compile_seconds` per method, first call less median).
    `value_seconds`: the objective alone on the same paths; `gradient_forward_ratio`: the reverse
    pass (value and every sensitivity) over it, both timed in this call."""

    value: float = field(json=False)
    sensitivities: dict
    adjoint_seconds: float
    value_seconds: float
    gradient_forward_ratio: float
    bump_seconds: float | None
    forward_mode_seconds: float | None
    speedup: float | None
    forward_mode_speedup: float | None
    max_rel_diff: float | None
    max_rel_diff_forward_mode: float | None
    compile_seconds: dict
    gradient: dict = field(json=False)
    comparison: BumpComparison | None = field(json=False, default=None)

    def summary(self) -> str:
        text = f"adjoint {self.adjoint_seconds:.4f} s ({self.gradient_forward_ratio:.2f}x the value alone)"
        if self.speedup is not None:
            text += (f"; bump {self.bump_seconds:.3f} s (speedup {self.speedup:.0f}x, max rel diff "
                     f"{self.max_rel_diff:.1e}); forward mode {self.forward_mode_seconds:.3f} s")
        return text


@dataclasses.dataclass(frozen=True, kw_only=True)
class ALMStudy(Result):
    """The `snapo alm` study (JSON keys in docs/alm.md): the fund with `n_risk_factors` reported
    factors (`layout`), the policy (trained, or not) evaluated hard and smooth on `paths` fresh
    paths against the fixed-mix `baselines`, and its sensitivities (`measurement`, whose fields
    sit at the top level of the JSON). Carries the `policy` and the evaluation `shocks`. `fund`:
    the fund file's name (null: the built-in fund built for N); `initial_funding_ratio`: assets
    over liabilities at the start, valued as the simulation values them, with those liabilities'
    `initial_liability_value` [million] and `liability_duration` [years, -dL/ds / L]; `scenarios`: "generated"
    or the scenario file the study ran on; `board`: the board's figures (`_board.board_figures`:
    `funding_ratio_percentiles`, `p_underfunded`, `surplus_at_risk`, `hedge_ratio`,
    `key_rate_durations`), top-level keys of the JSON; `baselines`: each fixed mix's evaluation
    and its `board` figures, the fund's strategic mix first where its file names one
    (`strategic_mix`: its weights, null where it names none)."""

    n_risk_factors: int
    layout: dict
    paths: int
    horizon_months: int
    effects: list
    trained: bool
    evaluation: Evaluation = field(json=False)
    baselines: dict
    train_seconds: float
    train_compile_seconds: float = field(json=False, default=0.0)
    measurement: SensitivityMeasurement = field(json=False)
    policy: AbstractRebalancing = field(json=False)
    shocks: jax.Array = field(json=False)
    fund: str | None = None
    initial_funding_ratio: float | None = None
    scenarios: str = "generated"
    board: dict = field(json=False, default_factory=dict)
    strategic_mix: dict | None = None
    initial_liability_value: float | None = None
    liability_duration: float | None = None

    def to_json(self) -> dict:
        payload = {**super().to_json(), **self.evaluation.to_json(), **self.measurement.to_json(), **self.board}
        payload["compile_seconds"] = {**payload["compile_seconds"], "train": self.train_compile_seconds}
        return payload

    def summary(self) -> str:
        name = f"{self.fund}, " if self.fund else ""
        valued = ("" if self.initial_liability_value is None else
                  f" (liabilities {self.initial_liability_value:,.2f} million, duration {self.liability_duration:.2f} years)")
        lines = [f"{name}N = {self.n_risk_factors}, starting at a funding ratio of {self.initial_funding_ratio:.4f}{valued}: "
                 f"{self.evaluation.summary()} at {self.horizon_months} months"]
        lines += [f"  {name}: objective {baseline['objective']:.6f}" for name, baseline in self.baselines.items()]
        lines.append(self.measurement.summary())
        return "\n".join(lines)


def funding_ratio_statistics(funding_ratio) -> dict[str, float]:
    """Mean, 5/50/95% quantiles and the probability of underfunding (< 1) at the horizon."""
    values = to_host(funding_ratio)
    p05, p50, p95 = np.quantile(values, [0.05, 0.5, 0.95])
    return dict(mean=float(values.mean()), p05=float(p05), p50=float(p50), p95=float(p95),
                probability_below_1=float(np.mean(values < 1.0)))
