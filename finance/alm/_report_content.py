"""What the ALM report shows: a summary, the funding ratio and objective of the policy against the
fixed mixes, the sensitivity ladder, the policy's behaviour and the methods. Every number is a
`Value` (a path into the report's JSON); the figures are drawn from the JSON only."""

import numpy as np

from snapo_ode import Figure, Heading, Highlights, Paragraph, Section, Table, Value

from ._factors import tenor_label

V = Value
GROUP_TITLES = {"key_rates": "Key rates", "inflation": "Inflation", "spread": "Credit spread",
                "equity_levels": "Equity levels"}
MAP_POINTS = (0.9, 1.0, 1.1, 1.3)  # funding ratios at which the policy's weights are tabulated


def _policy_paths(data: dict, name: str) -> dict:
    """Where a policy's evaluation lies in the JSON: the studied policy at the top, mixes under baselines."""
    base = () if name == data["policy_names"][0] else ("baselines", name)
    return {"objective": (*base, "objective"), "objective_smooth": (*base, "objective_smooth"),
            "funding_ratio": (*base, "funding_ratio"), "mean_surplus": (*base, "mean_surplus")}


def summary_section(data: dict) -> Section:
    policy = data["policy_names"][0]
    best_mix = max(data["baselines"], key=lambda name: data["baselines"][name]["objective"])
    ladder = data["ladder"]
    cards = [("Objective, " + policy, V(("objective",), ".4f"), ("exact constraints; smooth ",
                                                                     V(("objective_smooth",), ".4f"))),
             ("Best fixed mix: " + best_mix, V(("baselines", best_mix, "objective"), ".4f"), ("objective, same paths",)),
             ("Mean funding ratio at the horizon", V(("funding_ratio", "mean"), ".3f"),
              ("p05 quantile ", V(("funding_ratio", "p05"), ".3f"))),
             ("P(funding ratio below one) at the horizon", V(("funding_ratio", "probability_below_1"), ".2%"), ())]
    if "key_rates" in ladder:
        cards.append(("E[funding ratio] per basis point on every key rate", V(("ladder", "key_rates", "total_funding_ratio"), ".2e"),
                      ("objective ", V(("ladder", "key_rates", "total_objective"), ".2e"))))
    if "inflation" in ladder:
        cards.append(("E[funding ratio] per basis point of inflation", V(("ladder", "inflation", "total_funding_ratio"), ".2e"),
                      ("objective ", V(("ladder", "inflation", "total_objective"), ".2e"))))
    return Section("Summary", (
        Highlights(tuple(cards)),
        Paragraph(("The ", policy, " reaches an objective of ", V(("objective",), ".4f"), " against ",
                   V(("baselines", best_mix, "objective"), ".4f"), " for the best fixed mix (", best_mix, ") on the same ",
                   V(("paths",), ",d"), " fresh paths, with a probability of underfunding at the horizon of ",
                   V(("funding_ratio", "probability_below_1"), ".2%"), " against ",
                   V(("baselines", best_mix, "funding_ratio", "probability_below_1"), ".2%"), ". Every sensitivity "
                   "below comes from one reverse pass through the whole simulation."), "finding")))


def outcome_section(data: dict) -> Section:
    rows = []
    for name in data["policy_names"]:
        p = _policy_paths(data, name)
        rows.append((name, V(p["objective"], ".5f"), V(p["objective_smooth"], ".5f"),
                     V((*p["funding_ratio"], "mean"), ".4f"), V((*p["funding_ratio"], "p05"), ".4f"),
                     V((*p["funding_ratio"], "p50"), ".4f"), V((*p["funding_ratio"], "p95"), ".4f"),
                     V((*p["funding_ratio"], "probability_below_1"), ".2%"), V(p["mean_surplus"], ".4f")))
    return Section("Funding ratio and objective", (
        Table(("policy", "objective", "objective, smooth", "funding ratio: mean", "p05", "p50", "p95",
               "P(below one)", "mean surplus"), tuple(rows),
              ("At the horizon, on the same ", V(("paths",), ",d"), " fresh paths (never trained on), exact constraints",),
              csv="policies.csv"),
        Figure.from_matplotlib(_distribution_figure(data), ("The funding ratio at the horizon: its distribution under each "
                                                            "policy (quantiles from one to ninety-nine percent)",),
                               "distribution of the terminal funding ratio", width="70%")))


def ladder_section(data: dict) -> Section:
    blocks = [Paragraph(("The change of the objective and of the expected funding ratio at the horizon when one "
                         "factor moves by the shift shown, the policy and the random numbers held: the sensitivity "
                         "from one reverse pass times the shift. Rows of a group add up to the group's parallel "
                         "shift.",))]
    for group, title in GROUP_TITLES.items():
        if group not in data["ladder"]:
            continue
        rows = tuple((V(("ladder", group, "rows", k, "factor")), V(("ladder", group, "rows", k, "shift")),
                      V(("ladder", group, "rows", k, "objective"), ".3e"),
                      V(("ladder", group, "rows", k, "funding_ratio"), ".3e"))
                     for k in range(len(data["ladder"][group]["rows"])))
        total = (("all together",), V(("ladder", group, "shift")), V(("ladder", group, "total_objective"), ".3e"),
                 V(("ladder", group, "total_funding_ratio"), ".3e"))
        blocks.append(Table(("factor", "shift", "objective", "E[funding ratio]"), rows + (total,), (title,)))
    if "key_rates" in data["ladder"]:
        blocks.insert(1, Figure.from_matplotlib(_key_rate_figure(data), ("The key-rate ladder: per basis point at each "
                                                                          "tenor",), "key-rate ladder", width="88%"))
    blocks.append(Paragraph(("Every reported factor's sensitivity (liability cash flows, volatilities and holdings "
                             "too, where reported) is in sensitivities.csv.",), "note"))
    return Section("Sensitivity ladder", tuple(blocks))


def policy_section(data: dict) -> Section:
    ratios = np.asarray(data["policy_map"]["funding_ratio"])
    columns = [int(np.argmin(np.abs(ratios - r))) for r in MAP_POINTS]
    rows = []
    for name in data["policy_names"]:
        for k in columns:
            rows.append((name, V(("policy_map", "funding_ratio", k), ".3g"),
                         *(V(("policy_map", "weights", name, asset, k), ".1%") for asset in data["asset_classes"])))
    return Section("Policy behaviour", (
        Paragraph(("What each policy holds at the start as a function of the funding ratio, the market at its "
                   "initial state. A fixed mix holds the same weights whatever the funding ratio; the neural "
                   "policy reacts to it.",),),
        Figure.from_matplotlib(_policy_figure(data), ("Weights against the funding ratio at the start",),
                               "policy weights against the funding ratio", width="95%"),
        Table(("policy", "funding ratio", *data["asset_classes"]), tuple(rows), ("Weights at a few funding ratios",))))


def methods_section(data: dict) -> Section:
    return Section("Methods", (
        Heading("Model"),
        Paragraph(("A pension fund over ", V(("horizon_months",), "d"), " monthly steps on ", V(("paths",), ",d"),
                   " Monte Carlo paths: Vasicek key rates, equity indices, inflation and a credit spread, correlated; "
                   "liabilities valued on the simulated curve; a neural rebalancing policy (or a fixed mix) sets the "
                   "weights every month. Scenarios: ", V(("scenarios",)), "; fund: ", V(("fund",)), " (n/a: the "
                   "built-in one), starting at a funding ratio of ", V(("initial_funding_ratio",), ".4f"),
                   " (liabilities of ", V(("initial_liability_value",), ",.2f"), " million, each cash flow discounted at "
                   "its own date on the interpolated curve; duration ", V(("liability_duration",), ".2f"),
                   " years, which the liability-matching mix hedges). Effects: ", V(("effects_text",)), ". The objective is the expected "
                   "exponential utility of the discounted terminal surplus less a penalty on funding-ratio shortfalls "
                   "(docs/alm.md); reported with the exact constraints, and with the smooth surrogates used for "
                   "training and sensitivities."),),
        Heading("Sensitivities and their verification"),
        Table(("item", "value"), (
            ("reported risk factors", V(("n_risk_factors",), "d")),
            ("objective sensitivities, one reverse pass [s]", V(("adjoint_seconds",), ".4g")),
            ("expected funding ratio sensitivities, one reverse pass [s]", V(("funding_ratio_adjoint_seconds",), ".4g")),
            ("central bump-and-revalue [s]", V(("bump_seconds",), ".4g")),
            ("adjoint against central bumps, largest relative difference", V(("max_rel_diff",), ".2e")),
            ("adjoint against forward mode, largest relative difference", V(("max_rel_diff_forward_mode",), ".2e")),
            ("speedup of the adjoint over the bumps", V(("speedup",), ".3g")),
            ("policy trained", V(("trained",))),
            ("training [s]", V(("train_seconds",), ".4g")),
            ("everything computed for this report [s]", V(("report_seconds",), ".4g"))),
            ("Sensitivities, verification and timings (n/a where the bumps were not run)",)),
        Paragraph(("Sensitivities are of the smooth objective and the smooth expected funding ratio; evaluation "
                   "paths are never training paths.",), "note")))


def sections(data: dict) -> tuple[Section, ...]:
    from ._report_board import board_section

    return (summary_section(data), outcome_section(data), board_section(data), ladder_section(data),
            policy_section(data), methods_section(data))


def _distribution_figure(data: dict):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(6.0, 3.0))
    levels = np.linspace(0.01, 0.99, 99)
    for name, quantiles in data["terminal_funding_ratio_quantiles"].items():
        axis.plot(quantiles, levels, label=name, lw=1.6)
    axis.axvline(1.0, color="k", lw=0.8, ls=":")
    axis.set_xlabel("funding ratio at the horizon")
    axis.set_ylabel("probability below")
    axis.legend(fontsize=8, frameon=False)
    figure.tight_layout()
    return figure


def _key_rate_figure(data: dict):
    import matplotlib.pyplot as plt

    rows = data["ladder"]["key_rates"]["rows"]
    tenors = [tenor_label(t) for t in data["key_tenors"]]
    figure, axes = plt.subplots(1, 2, figsize=(8.0, 2.6))
    for axis, key, title in ((axes[0], "objective", "objective per +1 bp"),
                             (axes[1], "funding_ratio", "E[funding ratio] per basis point")):
        axis.bar(tenors, [r[key] for r in rows], color="#4c78a8")
        axis.axhline(0, color="k", lw=0.8)
        axis.set_title(title, fontsize=9)
        axis.tick_params(labelsize=7, axis="x", rotation=60)
        axis.tick_params(labelsize=7, axis="y")
    figure.tight_layout()
    return figure


def _policy_figure(data: dict):
    import matplotlib.pyplot as plt

    ratios = data["policy_map"]["funding_ratio"]
    names = data["policy_names"]
    figure, axes = plt.subplots(1, len(names), figsize=(3.0 * len(names), 2.8), sharey=True)
    for axis, name in zip(np.atleast_1d(axes), names, strict=True):
        weights = data["policy_map"]["weights"][name]
        assets = data["asset_classes"]
        axis.stackplot(ratios, *(weights[a] for a in assets), labels=assets, alpha=0.85)
        axis.set_title(name, fontsize=9)
        axis.set_xlabel("funding ratio", fontsize=8)
        axis.set_xlim(ratios[0], ratios[-1])
        axis.set_ylim(0, 1)
        axis.tick_params(labelsize=7)
    np.atleast_1d(axes)[0].set_ylabel("weight", fontsize=8)
    np.atleast_1d(axes)[-1].legend(fontsize=6.5, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False)
    figure.tight_layout()
    return figure
