"""`snapo report alm --out DIR`: the pension fund's risk report. The funding ratio and the
objective of the trained policy against fixed mixes on the same fresh paths, and a sensitivity
ladder: the objective's and the expected funding ratio's sensitivity to every key rate, to
inflation, to the equity indices and to the credit spread, each from one reverse pass, scaled to
a basis point (rates) or a 1% move (equity levels). This module computes the JSON's data; the
content is in `_report_content`; the core writes the files."""

import pathlib

import equinox as eqx
import jax.numpy as jnp
import numpy as np

import snapo_ode
from snapo_ode import Report, mesh_of, per_sample, sample_mean, to_host, value_and_sensitivities

from ._assets import initial_prices, zero_rate
from ._factors import factor_names, named_sensitivities
from ._market import MONTH
from ._model import initial_values, simulate
from ._report_check import DEFAULT_BUMP_SAMPLE, sampled_bump_check
from ._sensitivities import PATH_SPECS
from ._baselines import baselines
from ._study import run_alm, study_for

BASIS_POINT = 1e-4
# The ladder's groups: (group, shift per entry, the shift in words). Rates move by a basis point;
# an equity level (1 at the reference date) by 1% of itself.
LADDER = (("key_rates", BASIS_POINT, "+1 bp"), ("inflation", BASIS_POINT, "+1 bp"),
          ("spread", BASIS_POINT, "+1 bp"), ("equity_levels", 0.01, "+1%"))
FUNDING_RATIOS = np.linspace(0.7, 1.5, 33)  # of the policy map
# The shift a reader is shown per group: (shift, the shift in words); the funding ratio's change
# for it is the sensitivity times the shift (first order), in percentage points.
READER_SHIFTS = {"key_rates": (0.01, "+100 bp"), "inflation": (0.01, "+100 bp"), "spread": (0.01, "+100 bp"),
                 "equity_levels": (0.10, "+10%")}
MARKET_BUCKETS = (1.0, 2.0, 3.0, 5.0, 7.0, 10.0, 15.0, 20.0, 30.0, 40.0, 50.0)  # key-rate buckets [years]
DEFAULT_CURRENCY = "EUR"  # the built-in fund's, as a fund file's default


@eqx.filter_jit
def _mean_funding_ratio_and_gradient(problem, policy, reported, fixed, shocks, mesh):
    def mean_funding_ratio(reported, policy, shocks):
        outcome = simulate(problem, policy, {**fixed, **reported}, shocks, smooth_constraints=True)
        return jnp.mean(outcome.funding_ratio)

    return value_and_sensitivities(sample_mean(mean_funding_ratio, mesh, PATH_SPECS), reported, policy, shocks)


def policy_map(study, policy) -> dict:
    """The weights each policy chooses at the start against the funding ratio, the market at its
    initial state: asset -> list over FUNDING_RATIOS."""
    factors = {**study.fixed, **study.reported}
    rates = jnp.asarray(factors["key_rates"])[None, :]
    n = FUNDING_RATIOS.size
    features = jnp.stack([jnp.zeros(n), jnp.asarray(FUNDING_RATIOS),
                          jnp.full(n, zero_rate(rates, study.market, MONTH)[0]), jnp.full(n, rates[0, -1]),
                          jnp.full(n, factors["inflation"]), jnp.full(n, factors["spread"])], axis=1)
    weights = np.asarray(policy(features))
    return {asset: weights[:, k].tolist() for k, asset in enumerate(study.market.asset_names)}


def terminal_funding_ratios(study, policies: dict, shocks) -> dict:
    """Each policy's funding ratio at the horizon on every path (exact constraints), as quantiles
    (1% to 99%) for the distribution figure."""
    factors = {**study.fixed, **study.reported}
    run = eqx.filter_jit(per_sample(
        lambda policy, factors, shocks: simulate(study.problem, policy, factors, shocks, smooth_constraints=False),
        mesh_of(shocks), PATH_SPECS))
    levels = np.linspace(0.01, 0.99, 99)
    return {name: np.quantile(to_host(run(policy, factors, shocks).funding_ratio), levels).tolist()
            for name, policy in policies.items()}


def ladder(objective: dict, funding_ratio: dict, names: dict, reported) -> dict:
    """group -> rows {factor, shift, objective (change of J), funding_ratio (change of E[FR_T]),
    funding_ratio_pp (E[FR_T]'s change for the group's `READER_SHIFTS` shift, in percentage
    points)} for the shift of LADDER, plus each group's total (a parallel shift of every entry)."""
    out = {}
    for group, shift, words in LADDER:
        if group not in reported:
            continue
        big, big_words = READER_SHIFTS[group]
        rows = [{"factor": name, "shift": words, "objective": objective[name] * shift,
                 "funding_ratio": funding_ratio[name] * shift, "funding_ratio_pp": funding_ratio[name] * big * 100}
                for name in names[group]]
        out[group] = {"rows": rows, "shift": words, "reader_shift": big_words,
                      "total_objective": float(sum(r["objective"] for r in rows)),
                      "total_funding_ratio": float(sum(r["funding_ratio"] for r in rows)),
                      "total_funding_ratio_pp": float(sum(r["funding_ratio_pp"] for r in rows))}
    return out


def bucket_weights(tenors, buckets=MARKET_BUCKETS) -> np.ndarray:
    """The linear map (buckets, tenors) that moves a key-rate figure at each model tenor onto the
    market buckets around it, split in proportion to the distance (a tenor beyond the first or
    last bucket goes wholly to it); columns sum to one, so totals are kept. Buckets past the
    longest tenor's neighbour are left out."""
    tenors, buckets = np.asarray(tenors, float), np.asarray(buckets, float)
    last = min(int(np.searchsorted(buckets, tenors.max())), buckets.size - 1)
    buckets = buckets[:last + 1]
    weights = np.zeros((buckets.size, tenors.size))
    for j, t in enumerate(tenors):
        k = int(np.searchsorted(buckets, t))
        if k == 0 or k == buckets.size:
            weights[min(k, buckets.size - 1), j] = 1.0
        else:
            share = (buckets[k] - t) / (buckets[k] - buckets[k - 1])
            weights[k - 1, j], weights[k, j] = share, 1.0 - share
    return weights


def market_buckets(tenors, series: dict) -> dict:
    """Each list of `series` (one value per model tenor) on the market buckets (`bucket_weights`),
    with `tenors` the buckets [years]."""
    weights = bucket_weights(tenors)
    out = {key: (weights @ np.asarray(values, float)).tolist() for key, values in series.items()}
    return {"tenors": list(MARKET_BUCKETS[:weights.shape[0]]), **out}


def starting_position(study, currency: str) -> dict:
    """The fund at the start, valued as the simulation values it: assets and liabilities
    [million], their funding ratio, and the mix (asset class -> share of the assets; the equity
    indices together as the last class)."""
    factors = {**study.fixed, **study.reported}
    assets, liabilities = (float(v) for v in initial_values(study.problem, factors))
    prices = initial_prices(factors, study.market, credit=study.problem.scene.has("credit"))
    held = np.asarray(factors["holdings"]) * np.asarray(prices)
    names = study.market.asset_names
    values = [*held[:len(names) - 1], held[len(names) - 1:].sum()]
    return {"currency": currency, "assets": assets, "liabilities": liabilities, "surplus": assets - liabilities,
            "funding_ratio": assets / liabilities,
            "mix": {name: float(v / sum(values)) for name, v in zip(names, values, strict=True)}}


def build_alm_report(n_risk_factors: int = 100, *, n_paths: int = 1000, horizon_months: int | None = None,
                     train_steps: int = 300, train_paths: int = 256, bump: bool = True, seed: int = 0,
                     progress: bool = True, checkpoint_path=None, resume: bool = False, mesh=None,
                     fund=None, scenario_set=None, bump_sample: int = DEFAULT_BUMP_SAMPLE) -> dict:
    """Every number of the ALM report, as the JSON document's data (see docs/alm.md), for the
    built-in fund or `fund` (`load_fund`), on generated paths or its `scenario_set`
    (`load_scenarios`); `mesh`: the devices the paths split over. With `bump`, the adjoint is
    checked against central bumps on `bump_sample` of its sensitivities (`sampled_bump_check`:
    the largest and a seeded draw), or on every one (batched, with forward mode) when
    `bump_sample` is 0 or at least N."""
    import time

    start = time.perf_counter()
    study = study_for(n_risk_factors, fund, horizon_months, scenario_set)
    sampled = bump and 0 < bump_sample < study.layout.n_risk_factors
    result = run_alm(n_risk_factors, n_paths=n_paths, horizon_months=horizon_months, train_steps=train_steps,
                     bump=bump and not sampled, train_paths=train_paths, seed=seed, progress=progress,
                     checkpoint_path=checkpoint_path, resume=resume, mesh=mesh, fund=fund, scenario_set=scenario_set)
    timing, (ratio, gradient) = snapo_ode.time_function(
        _mean_funding_ratio_and_gradient, study.problem, result.policy, study.reported, study.fixed, result.shocks,
        mesh_of(result.shocks), repeats=3)
    funding_sensitivities = named_sensitivities(gradient, study.layout, study.market, study.problem.schedule)
    names = factor_names(study.layout, study.market, study.problem.schedule)
    mixes = baselines(study, None if fund is None else fund.strategic_mix)
    policies = {"trained policy" if result.trained else "untrained policy": result.policy, **mixes}
    data = result.to_json()
    flat_names = [name for group in sorted(study.reported) for name in names[group]]
    if sampled:
        check = sampled_bump_check(study, result.policy, result.shocks, result.measurement.gradient, flat_names,
                                   size=bump_sample, seed=seed, progress=progress)
        data.update(check)
    else:
        data.update(bump_checked=data["n_risk_factors"] if data.get("max_rel_diff") is not None else 0,
                    bump_total=data["n_risk_factors"], worst_factor=None, checked=None)
    for key in ("max_rel_diff", "max_rel_diff_forward_mode"):  # for a reader, in parts per million
        data[f"{key}_ppm"] = None if data.get(key) is None else data[key] * 1e6
    position = starting_position(study, DEFAULT_CURRENCY if fund is None else fund.currency)
    durations = data["key_rate_durations"]
    data.update(
        currency=position["currency"], starting_position=position,
        asset_class_names={name: asset_class_name(name) for name in study.market.asset_names},
        key_rate_durations_buckets=market_buckets(durations["tenors"], {
            "assets": durations["assets"], "liabilities": durations["liabilities"], "surplus": durations["surplus"],
            "surplus_dv01": durations["dv01"]["surplus"]}),
        funding_ratio_mean_smooth=float(ratio),
        funding_ratio_sensitivities=funding_sensitivities,
        funding_ratio_adjoint_seconds=timing.median_seconds,
        ladder=ladder(data["sensitivities"], funding_sensitivities, names, study.reported),
        key_tenors=[float(t) for t in study.market.tenors],
        asset_classes=list(study.market.asset_names),
        factor_groups={group: names[group] for group in study.layout.reported},
        policy_map={"funding_ratio": FUNDING_RATIOS.tolist(),
                    "weights": {name: policy_map(study, policy) for name, policy in policies.items()}},
        terminal_funding_ratio_quantiles=terminal_funding_ratios(study, policies, result.shocks),
        policy_names=list(policies),
        effects_text=", ".join(data["effects"]),
        report_seconds=time.perf_counter() - start,
    )
    if "key_rates" in data["ladder"]:
        rows = data["ladder"]["key_rates"]["rows"]
        data["ladder"]["key_rates"]["buckets"] = market_buckets(
            data["key_tenors"], {"funding_ratio_pp": [r["funding_ratio_pp"] for r in rows],
                                 "objective": [r["objective"] for r in rows]})
    return data


ASSET_CLASS_NAMES = {"cash": "Cash", "bond_short": "Government bonds, short", "bond_long": "Government bonds, long",
                     "inflation_linked": "Inflation-linked bonds", "credit": "Corporate bonds", "equity": "Equities"}


def asset_class_name(name: str) -> str:
    """An asset class as a reader names it ("bond_long" -> "Government bonds, long"); a class of
    a fund file's own, its name in words."""
    return ASSET_CLASS_NAMES.get(name, name.replace("_", " ").capitalize())


def alm_report(data: dict, provenance: dict) -> Report:
    from ._report_content import sections

    return Report(name="alm", title="Pension fund ALM: funding ratio, policy and sensitivity report", data=data,
                  provenance=provenance, sections=sections(data),
                  subtitle=("Risk factors ", snapo_ode.Value(("n_risk_factors",), "d"), ", Monte Carlo paths ",
                            snapo_ode.Value(("paths",), ",d"), ", horizon ", snapo_ode.Value(("horizon_months",), "d"),
                            " months; computed at ", snapo_ode.Value(("provenance", "timestamp_utc")), "."),
                  csv={"sensitivities.csv": [["factor", "group", "objective_sensitivity", "funding_ratio_sensitivity"]]
                       + [[name, group, data["sensitivities"][name], data["funding_ratio_sensitivities"][name]]
                          for group, names in data["factor_groups"].items() for name in names]})


def report_provenance(n_risk_factors: int, settings: dict, command=None, fund=None, scenario_file=None) -> dict:
    """The report's provenance: its settings, N and, for a `fund` (`load_fund`), the SHA-256 of
    its fund and liability files, and of the `scenario_file` it ran on."""
    inputs = {"settings": settings, "risk_factors": n_risk_factors}
    if fund is not None:
        inputs.update(fund_file=fund.files[0], liability_file=fund.files[1])
    if scenario_file is not None:
        inputs["scenario_file"] = pathlib.Path(scenario_file)
    return snapo_ode.provenance(inputs, command=command)

