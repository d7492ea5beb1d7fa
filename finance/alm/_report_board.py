"""The board's page of the ALM report: the funding-ratio fan chart, the probability of
underfunding and surplus at risk at the board's dates, the hedge ratio and the key-rate
durations (`_board.py` computes them; every number here is a `Value` into the JSON)."""

from snapo_ode import Figure, Highlights, Paragraph, Section, Table, Value

from ._factors import tenor_label


def money(data: dict) -> str:
    """The unit of the report's money: millions of the fund's currency."""
    return f"million {data['currency']}"


V = Value


def board_section(data: dict) -> Section:
    unit = money(data)
    dates = data["p_underfunded"]["months"]
    last = len(dates) - 1
    required = V(("p_underfunded", "required_funding_ratio"), ".0%")
    cards = (("Hedge ratio: the assets' DV01 over the liabilities'", V(("hedge_ratio",), ".1%"),
              ("a parallel shift of the key rates, at the start",)),
             ("Probability of underfunding at the last date", V(("p_underfunded", "below_1", last), ".1%"),
              ("month ", V(("p_underfunded", "months", last), "d"), "; a funding ratio below one")),
             ("Probability of a funding ratio below the required level at the last date",
              V(("p_underfunded", "below_required", last), ".1%"), ("required: ", required)),
             ("Surplus at risk at the first date", V(("surplus_at_risk", "surplus_at_risk", 0), ",.1f", " " + unit),
              ("month ", V(("surplus_at_risk", "months", 0), "d"), ", confidence ",
               V(("surplus_at_risk", "confidence"), ".1%"), "; a loss, from the initial surplus (negative: even "
               "the bad case gains)")))
    rows = tuple((V(("p_underfunded", "months", k), "d"), V(("p_underfunded", "below_1", k), ".1%"),
                  V(("p_underfunded", "below_required", k), ".1%"), V(("surplus_at_risk", "surplus_at_risk", k), ",.1f"),
                  V(("surplus_at_risk", "expected_shortfall", k), ",.1f"))
                 for k in range(len(dates)))
    buckets = ("key_rate_durations_buckets",)
    durations = tuple((V((*buckets, "tenors", k), "g", " y"), V((*buckets, "assets", k), ".2f"),
                       V((*buckets, "liabilities", k), ".2f"), V((*buckets, "surplus", k), ".2f"),
                       V((*buckets, "surplus_dv01", k), ",.3f"))
                      for k in range(len(data[buckets[0]]["tenors"])))
    return Section("For the board", (
        Highlights(cards),
        Figure.from_matplotlib(_fan_figure(data), ("The funding ratio over the horizon under the studied policy: the "
                                                   "median, the middle half and the middle nine-tenths of the paths, "
                                                   "exact constraints",),
                               "funding-ratio fan chart", width="80%"),
        Table(("month", "P(funding ratio below one)", "P(below the required level)", f"surplus at risk [{unit}]",
               f"expected shortfall [{unit}]"),
              rows, ("At the board's dates (required level ", required, "): surplus at risk is the loss from the "
                     "initial surplus to the ", V(("surplus_at_risk", "confidence"), ".1%"), "-confidence low quantile "
                     "of the surplus discounted by the bank account; expected shortfall the loss to the mean beyond it "
                     "(initial surplus ", V(("surplus_at_risk", "initial_surplus"), ",.1f", " " + unit), "). Both read "
                     "as losses: positive, the fund loses that much; negative, even the bad case ends above the "
                     "initial surplus"), csv="board.csv"),
        Figure.from_matplotlib(_duration_figure(data), ("Key-rate durations at the start at market buckets: -dV/dr "
                                                        "per bucket over the value (the surplus's over the liabilities)",),
                               "key-rate durations", width="80%"),
        Table(("key rate", "assets [years]", "liabilities [years]", "surplus [years of liabilities]",
               f"surplus DV01 [{unit} per bp]"), durations,
              ("Key-rate durations (forward-mode AD at the start), the model's tenors split onto market buckets",)),
        Paragraph(("Durations add up over the tenors to the parallel duration; the hedge ratio is the assets' parallel "
                   "DV01 over the liabilities'. A DV01 is the value gained when every rate falls by one basis point "
                   "(-dV/dr times a basis point): positive for a long bond position, and the liabilities' is positive too.",),
                  "note"),
        *comparison_blocks(data)))


def comparison_blocks(data: dict) -> tuple:
    """The board's figures of the studied policy beside each fixed mix (the fund's strategic mix
    first, where its file names one) at every board date, and the strategic mix's weights."""
    policy = data["policy_names"][0]
    sources = [(policy, ())] + [(name, ("baselines", name, "board")) for name in data["baselines"]]
    rows = []
    for name, base in sources:
        for k, month in enumerate(data["p_underfunded"]["months"]):  # the fan holds every month-end from 0
            rows.append((name, V((*base, "p_underfunded", "months", k), "d"),
                         V((*base, "p_underfunded", "below_1", k), ".1%"),
                         V((*base, "p_underfunded", "below_required", k), ".1%"),
                         V((*base, "surplus_at_risk", "surplus_at_risk", k), ",.1f"),
                         V((*base, "surplus_at_risk", "expected_shortfall", k), ",.1f"),
                         V((*base, "funding_ratio_percentiles", "p05", month), ".1%"),
                         V((*base, "funding_ratio_percentiles", "p50", month), ".1%")))

    table = Table(("policy", "month", "P(funding ratio below one)", "P(below the required level)",
                   f"surplus at risk [{money(data)}]", f"expected shortfall [{money(data)}]", "funding ratio p05",
                   "median"),
                  tuple(rows), ("The board's figures of each policy on the same paths, exact constraints: the "
                                "studied policy, then the fixed mixes",), csv="board_policies.csv")
    if data.get("strategic_mix") is None:
        mix = Paragraph(("The fund file names no strategic mix (assets.strategic_mix), so none is compared.",), "note")
    else:
        mix = Table(("asset class", "strategic weight"),
                    tuple((data["asset_class_names"].get(name, name), V(("strategic_mix", name), ".1%"))
                          for name in data["strategic_mix"]),
                    ("The fund's strategic mix (from its file), rebalanced to every month",))
    return table, mix


def _fan_figure(data: dict):
    import matplotlib.pyplot as plt

    fan = data["funding_ratio_percentiles"]
    months = fan["months"]
    figure, axis = plt.subplots(figsize=(6.4, 3.0))
    axis.fill_between(months, fan["p05"], fan["p95"], color="#4c78a8", alpha=0.2, lw=0, label="5-95%")
    axis.fill_between(months, fan["p25"], fan["p75"], color="#4c78a8", alpha=0.4, lw=0, label="25-75%")
    axis.plot(months, fan["p50"], color="#1f3b73", lw=1.6, label="median")
    axis.axhline(1.0, color="k", lw=0.8, ls=":")
    axis.axhline(data["p_underfunded"]["required_funding_ratio"], color="#b22222", lw=0.8, ls="--", label="required")
    axis.set_xlabel("month")
    axis.set_ylabel("funding ratio")
    axis.legend(fontsize=7, frameon=False, ncol=4)
    figure.tight_layout()
    return figure


def _duration_figure(data: dict):
    import matplotlib.pyplot as plt
    import numpy as np

    durations = data["key_rate_durations_buckets"]
    labels = [tenor_label(t) for t in durations["tenors"]]
    x = np.arange(len(labels))
    figure, axis = plt.subplots(figsize=(7.0, 2.8))
    for offset, key in ((-0.27, "assets"), (0.0, "liabilities"), (0.27, "surplus")):
        axis.bar(x + offset, durations[key], width=0.27, label=key)
    axis.axhline(0, color="k", lw=0.8)
    axis.set_xticks(x, labels, rotation=60, fontsize=7)
    axis.set_ylabel("years", fontsize=8)
    axis.legend(fontsize=7, frameon=False)
    figure.tight_layout()
    return figure
