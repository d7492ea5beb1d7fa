"""What the ALM report shows: a summary, the funding ratio and objective of the policy against the
fixed mixes, the sensitivity ladder, the policy's behaviour and the methods. Every number is a
`Value` (a path into the report's JSON); the figures are drawn from the JSON only."""

import numpy as np

from snapo_ode import Figure, Heading, Highlights, Paragraph, Section, Table, Value

from ._factors import tenor_label
from ._report_board import board_section, money

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
    ladder, unit, start = data["ladder"], money(data), ("starting_position",)
    cards = [("Assets at the start", V((*start, "assets"), ",.1f", unit), ()),
             ("Liabilities at the start", V((*start, "liabilities"), ",.1f", unit),
              ("duration ", V(("liability_duration",), ".1f", " years"))),
             ("Funding ratio at the start", V((*start, "funding_ratio"), ".1%"), ("assets over liabilities",)),
             ("Mean funding ratio at the horizon", V(("funding_ratio", "mean"), ".1%"),
              (policy, "; the worst twentieth of paths end below ", V(("funding_ratio", "p05"), ".1%"))),
             ("Probability of underfunding at the horizon",
              V(("funding_ratio", "probability_below_1"), ".1%"), (policy, "; a funding ratio below one"))]
    for group, title, words in (("key_rates", "Key rates, a parallel rise", " on every key rate"),
                                ("inflation", "Inflation, a rise", " on inflation")):
        if group in ladder:
            cards.append((title, V(("ladder", group, "total_funding_ratio_pp"), "+.1f", " pp"),
                          (V(("ladder", group, "reader_shift")), words, ": the expected funding ratio at the horizon, "
                           "first order",)))
    mix = Table(("asset class", "share of the assets"),
                tuple((data["asset_class_names"][name], V((*start, "mix", name), ".1%"))
                      for name in data["starting_position"]["mix"]),
                ("The mix at the start",))
    return Section("Summary", (
        Highlights(tuple(cards)),
        mix,
        Paragraph(("Starting from a funding ratio of ", V((*start, "funding_ratio"), ".1%"), " (assets of ",
                   V((*start, "assets"), ",.0f", unit), " against liabilities of ", V((*start, "liabilities"), ",.0f", unit),
                   "), the ", policy, " ends the horizon of ", V(("horizon_months",), "d"), " months at a mean funding "
                   "ratio of ", V(("funding_ratio", "mean"), ".1%"), ", underfunded with a probability of ",
                   V(("funding_ratio", "probability_below_1"), ".1%"), " against ",
                   V(("baselines", best_mix, "funding_ratio", "probability_below_1"), ".1%"), " for the best fixed mix (",
                   best_mix, ") on the same ", V(("paths",), ",d"), " fresh paths. Every sensitivity below comes from "
                   "one reverse pass through the whole simulation."), "finding"),
        Paragraph(("Money is in millions of ", V(("currency",)), "; a funding ratio is assets over liabilities, "
                   "both valued on the market curve; a change of a funding ratio is in percentage points (pp).",),
                  "note")))


def outcome_section(data: dict) -> Section:
    rows = []
    for name in data["policy_names"]:
        p = _policy_paths(data, name)
        rows.append((name, V(p["objective"], ".5f"), V(p["objective_smooth"], ".5f"),
                     V((*p["funding_ratio"], "mean"), ".1%"), V((*p["funding_ratio"], "p05"), ".1%"),
                     V((*p["funding_ratio"], "p50"), ".1%"), V((*p["funding_ratio"], "p95"), ".1%"),
                     V((*p["funding_ratio"], "probability_below_1"), ".1%"), V(p["mean_surplus"], ",.1f")))
    return Section("Funding ratio and objective", (
        Table(("policy", "objective", "objective, smooth", "funding ratio: mean", "p05", "p50", "p95",
               "P(underfunded)", f"mean surplus [{money(data)}]"), tuple(rows),
              ("At the horizon, on the same ", V(("paths",), ",d"), " fresh paths (never trained on), exact constraints; "
               "the objective is the fund's (an expected utility of the discounted surplus less a shortfall penalty, "
               "higher is better), in the units of that utility",),
              csv="policies.csv"),
        Figure.from_matplotlib(_distribution_figure(data), ("The funding ratio at the horizon: its distribution under each "
                                                            "policy (quantiles from one to ninety-nine percent)",),
                               "distribution of the terminal funding ratio", width="70%")))


def ladder_section(data: dict) -> Section:
    blocks = [Paragraph(("The change of the expected funding ratio at the horizon, in percentage points, when one "
                         "factor moves by the shift shown, the policy and the random numbers held: the sensitivity "
                         "from one reverse pass times the shift (first order). Rows of a group add up to the group's "
                         "parallel shift. Key rates are shown at market buckets: each model tenor's figure is split "
                         "between the two buckets around it in proportion to the distance.",))]
    for group, title in GROUP_TITLES.items():
        if group not in data["ladder"]:
            continue
        entry, shift = data["ladder"][group], V(("ladder", group, "reader_shift"))
        if group == "key_rates":
            buckets = entry["buckets"]
            rows = tuple((V(("ladder", group, "buckets", "tenors", k), "g", " y"), shift,
                          V(("ladder", group, "buckets", "funding_ratio_pp", k), "+.2f", " pp"))
                         for k in range(len(buckets["tenors"])))
        else:
            rows = tuple((V(("ladder", group, "rows", k, "factor")), shift,
                          V(("ladder", group, "rows", k, "funding_ratio_pp"), "+.2f", " pp"))
                         for k in range(len(entry["rows"])))
        total = (("all together",), shift, V(("ladder", group, "total_funding_ratio_pp"), "+.2f", " pp"))
        blocks.append(Table(("factor", "shift", "E[funding ratio] change"), rows + (total,), (title,)))
    if "key_rates" in data["ladder"]:
        blocks.insert(1, Figure.from_matplotlib(_key_rate_figure(data), ("The key-rate ladder at market buckets",),
                                                "key-rate ladder", width="70%"))
    blocks.append(Paragraph(("Every reported factor's sensitivity, of the objective and of the expected funding ratio, "
                             "at the model's own tenors (liability cash flows, volatilities and holdings too, where "
                             "reported), is in sensitivities.csv.",), "note"))
    return Section("Sensitivity ladder", tuple(blocks))


def policy_section(data: dict) -> Section:
    ratios = np.asarray(data["policy_map"]["funding_ratio"])
    columns = [int(np.argmin(np.abs(ratios - r))) for r in MAP_POINTS]
    rows = []
    for name in data["policy_names"]:
        for k in columns:
            rows.append((name, V(("policy_map", "funding_ratio", k), ".0%"),
                         *(V(("policy_map", "weights", name, asset, k), ".1%") for asset in data["asset_classes"])))
    return Section("Policy behaviour", (
        Paragraph(("What each policy holds at the start as a function of the funding ratio, the market at its "
                   "initial state. A fixed mix holds the same weights whatever the funding ratio; the neural "
                   "policy reacts to it.",),),
        Figure.from_matplotlib(_policy_figure(data), ("Weights against the funding ratio at the start",),
                               "policy weights against the funding ratio", width="95%"),
        Table(("policy", "funding ratio", *(data["asset_class_names"][a] for a in data["asset_classes"])), tuple(rows),
              ("Weights at a few funding ratios",))))


def methods_section(data: dict) -> Section:
    return Section("Methods", (
        Heading("Model"),
        Paragraph(("A pension fund over ", V(("horizon_months",), "d"), " monthly steps on ", V(("paths",), ",d"),
                   " Monte Carlo paths: Vasicek key rates, equity indices, inflation and a credit spread, correlated; "
                   "liabilities valued on the simulated curve; a neural rebalancing policy (or a fixed mix) sets the "
                   "weights every month. Scenarios: ", V(("scenarios",)), "; fund: ", V(("fund",)), " (n/a: the "
                   "built-in one, in ", V(("currency",)), "), starting at a funding ratio of ",
                   V(("initial_funding_ratio",), ".1%"), " (liabilities of ", V(("initial_liability_value",), ",.1f",
                                                                              money(data)),
                   ", each cash flow discounted at its own date on the interpolated curve; duration ",
                   V(("liability_duration",), ".1f"), " years, which the liability-matching mix hedges). Effects: ",
                   V(("effects_text",)), ". The objective is the expected exponential utility of the discounted "
                   "terminal surplus less a penalty on funding-ratio shortfalls (the ALM documentation); reported "
                   "with the exact constraints, and with the smooth surrogates used for training and "
                   "sensitivities."),),
        Heading("Sensitivities and their verification"),
        Paragraph(("The adjoint sensitivities were checked against central bump-and-revalue on ",
                   V(("bump_checked",), ",d"), " of the ", V(("bump_total",), ",d"), " (the largest and a seeded "
                   "random draw of the rest, or every one); the worst relative difference was ",
                   V(("max_rel_diff_ppm",), ",.3f", " ppm"), " (parts per million), at ", V(("worst_factor",)),
                   " (n/a: every one checked, or none)."),),
        Paragraph(("Sensitivities are of the smooth objective and the smooth expected funding ratio; evaluation "
                   "paths are never training paths. Solver settings and timings are in the appendix.",), "note")))


def appendix_section(data: dict) -> Section:
    return Section("Appendix: settings and timings", (
        Table(("item", "value"), (
            ("reported risk factors", V(("n_risk_factors",), "d")),
            ("objective sensitivities, one reverse pass", V(("adjoint_seconds",), ",.2f", " s")),
            ("expected funding ratio sensitivities, one reverse pass", V(("funding_ratio_adjoint_seconds",), ",.2f", " s")),
            ("central bump-and-revalue", V(("bump_seconds",), ",.2f", " s")),
            ("adjoint against forward mode, largest relative difference",
             V(("max_rel_diff_forward_mode_ppm",), ",.3f", " ppm")),
            ("speedup of the adjoint over the bumps (every one bumped)", V(("speedup",), ",.1f", "x")),
            ("policy trained", V(("trained",))),
            ("training", V(("train_seconds",), ",.1f", " s")),
            ("everything computed for this report", V(("report_seconds",), ",.1f", " s"))),
            ("Settings, verification and timings (n/a where not run)",)),))


def sections(data: dict) -> tuple[Section, ...]:

    return (summary_section(data), outcome_section(data), board_section(data), ladder_section(data),
            policy_section(data), methods_section(data), appendix_section(data))


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

    buckets = data["ladder"]["key_rates"]["buckets"]
    figure, axis = plt.subplots(figsize=(5.5, 2.6))
    axis.bar([tenor_label(t) for t in buckets["tenors"]], buckets["funding_ratio_pp"], color="#4c78a8")
    axis.axhline(0, color="k", lw=0.8)
    axis.set_ylabel("E[funding ratio] change [pp]", fontsize=8)
    axis.set_title(f"{data['ladder']['key_rates']['reader_shift']} at each key rate", fontsize=9)
    axis.tick_params(labelsize=7)
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
        axis.stackplot(ratios, *(weights[a] for a in assets), labels=[data["asset_class_names"][a] for a in assets],
                       alpha=0.85)
        axis.set_title(name, fontsize=9)
        axis.set_xlabel("funding ratio", fontsize=8)
        axis.set_xlim(ratios[0], ratios[-1])
        axis.set_ylim(0, 1)
        axis.tick_params(labelsize=7)
    np.atleast_1d(axes)[0].set_ylabel("weight", fontsize=8)
    np.atleast_1d(axes)[-1].legend(fontsize=6.5, loc="center left", bbox_to_anchor=(1.0, 0.5), frameon=False)
    figure.tight_layout()
    return figure
