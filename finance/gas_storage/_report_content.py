"""What the gas report shows: a summary, the value against its benchmarks, the monthly delta
ladder, the schedule, the facility sensitivities and the methods. Every number is a `Value` (a
path into the report's JSON); the figures are drawn from the JSON only."""

import numpy as np

from snapo_ode import Figure, Heading, Highlights, Paragraph, Section, Table, Value

V = Value


def summary_section(data: dict) -> Section:
    money, energy = data["currency"], data["energy_unit"]
    cards = [("Policy value, hard constraints", V(("value_hard",), ",.0f", " " + money), ()),
             ("Intrinsic value (exact LP)", V(("intrinsic_lp",), ",.0f", " " + money), ("on the forward curve",)),
             ("Hard value over the intrinsic", V(("hard_to_lp_ratio",), ".1%"), ()),
             ("Largest monthly delta", V(("largest_month", "delta"), ",.0f", " " + energy),
              (V(("largest_month", "month_name")),)),
             ("Worst hard-constraint violation", V(("max_constraint_violation",), ",.3f", " " + energy), ())]
    if data["lsmc_run"]:
        cards.insert(2, ("LSMC, out of sample", V(("lsmc_out_of_sample",), ",.0f", " " + money),
                         ("standard error ", V(("lsmc_se",), ",.0f", " " + money))))
    if data["has_dual_bound"]:
        cards.insert(3, ("Dual upper bound", V(("dual_upper_bound",), ",.0f", " " + money),
                         ("standard error ", V(("dual_upper_bound_se",), ",.0f", " " + money))))
    blocks = [Highlights(tuple(cards)),
              Paragraph(("The trained policy, evaluated with the exact constraints, is worth ",
                         V(("value_hard",), ",.0f", " " + money), ", ", V(("hard_to_lp_ratio",), ".1%"),
                         " of the intrinsic value from the exact linear program (", V(("intrinsic_lp",), ",.0f", " " + money),
                         "). The delta ladder, the schedule and every facility sensitivity come from one reverse pass "
                         "through the policy's simulation."), "finding"),
              Paragraph(("The contract starts on ", V(("start_date",)), " (", V(("start_date_source",)), "; n/a: no "
                         "date given, months counted from day zero); prices in ", V(("price_unit",)), ", money in ",
                         V(("currency",)), ", energy in ", V(("energy_unit",)), " (as given to the report: the curve "
                         "file carries no unit).",), "note")]
    if data["mode"] == "deterministic":
        blocks.insert(1, Paragraph(("This is the intrinsic value: prices follow the forward curve, known in advance, "
                                    "so the policy can at best match the linear program, and does. The extrinsic "
                                    "value (re-optimising as prices move) needs the stochastic run: snapo report gas "
                                    "--stochastic --lsmc, which also values least-squares Monte Carlo and its dual "
                                    "upper bound.",), "finding"))
    return Section("Summary", tuple(blocks))


def value_section(data: dict) -> Section:
    rows = [("policy, hard constraints (reported)", V(("value_hard",), ",.0f"), V(("value_hard_se",), ",.0f")),
            ("policy, smooth constraints (trained)", V(("value_smooth",), ",.0f"), V(("value_smooth_se",), ",.0f")),
            ("smooth less hard", V(("smoothing_gap",), ",.0f"), "-"),
            ("intrinsic value, exact LP", V(("intrinsic_lp",), ",.0f"), "-")]
    if data["lsmc_run"]:
        rows += [("LSMC, in sample", V(("lsmc_in_sample",), ",.0f"), V(("lsmc_in_sample_se",), ",.0f")),
                 ("LSMC, out of sample (same paths as the policy)", V(("lsmc_out_of_sample",), ",.0f"), V(("lsmc_se",), ",.0f")),
                 ("policy out of sample less LSMC, paired", V(("snapo_minus_lsmc",), ",.0f"),
                  V(("snapo_minus_lsmc_se",), ",.0f")),
                 ("perfect foresight (an upper bound, loose)", V(("perfect_foresight",), ",.0f"),
                  V(("perfect_foresight_se",), ",.0f"))]
    if data["has_dual_bound"]:
        rows.append(("information-relaxation dual upper bound", V(("dual_upper_bound",), ",.0f"),
                     V(("dual_upper_bound_se",), ",.0f")))
        for name, words in (("snapo", "policy"), ("lsmc", "LSMC")):
            if f"{name}_gap" in data:
                rows.append((f"{words}, cash less the bound's penalty (mean-zero control variate)",
                             V((f"{name}_value_control_variate",), ",.0f"),
                             V((f"{name}_value_control_variate_se",), ",.0f")))
                rows.append((f"{words}: duality gap, (bound - value) / bound (a fraction, not money)",
                             V((f"{name}_gap",), ".3%"), V((f"{name}_gap_se",), ".3%")))
    blocks = [Table(("value", data["currency"], f"standard error [{data['currency']}]"), tuple(rows),
                    ("The value against its benchmarks; n/a: deterministic (one path)",), csv="values.csv")]
    if not data["lsmc_run"]:
        blocks.append(Paragraph(("Least-squares Monte Carlo and its dual bound are not in this run: they need "
                                 "stochastic prices (--stochastic --lsmc).",), "note"))
    return Section("Value", tuple(blocks))


def ladder_section(data: dict) -> Section:
    lsmc = data["monthly_ladder"][0]["lsmc_delta"] is not None
    rows = tuple((V(("monthly_ladder", k, "month_name")), V(("monthly_ladder", k, "delta"), ",.0f"),
                  V(("monthly_ladder", k, "lp_delta"), ",.0f"),
                  *((V(("monthly_ladder", k, "lsmc_delta"), ",.0f"),) if lsmc else ()))
                 for k in range(len(data["monthly_ladder"])))
    total = (("total",), V(("ladder_totals", "delta"), ",.0f"), V(("ladder_totals", "lp_delta"), ",.0f"),
             *(("-",) if lsmc else ()))
    energy = data["energy_unit"]
    header = ("month", f"policy delta [{energy}]", f"LP envelope delta [{energy}]",
              *((f"LSMC pathwise delta [{energy}]",) if lsmc else ()))
    return Section("Monthly delta ladder", (
        Paragraph(("The change of the value per ", V(("price_unit",)), " added to the forward price of every day of the month: the "
                   "hedge volume of that month (positive: the facility is long gas then). The policy's deltas are of "
                   "its smooth value at the trained policy, from one reverse pass; the LP's by the envelope "
                   "theorem.",),),
        Figure.from_matplotlib(_ladder_figure(data), ("Monthly delta ladder",), "monthly delta ladder", width="85%"),
        Table(header, rows + (total,), ("Delta ladder by month",), csv="ladder.csv")))


def schedule_section(data: dict) -> Section:
    energy = data["energy_unit"]
    rows = tuple((V(("monthly_ladder", k, "month_name")), V(("monthly_ladder", k, "injection"), ",.0f"),
                  V(("monthly_ladder", k, "withdrawal"), ",.0f"), V(("monthly_ladder", k, "end_inventory"), ",.0f"))
                 for k in range(len(data["monthly_ladder"])))
    return Section("Schedule", (
        Figure.from_matplotlib(_schedule_figure(data), ("Inventory of the policy's hard schedule (mean over the "
                                                        "evaluation paths when stochastic) and of the LP, with the "
                                                        "forward curve",), "inventory schedule", width="85%"),
        Table(("month", f"injection [{energy}]", f"withdrawal [{energy}]", f"inventory at the end [{energy}]"), rows,
              ("The policy's schedule by month",))))


def sensitivity_section(data: dict) -> Section:
    rows = tuple((V(("facility_sensitivities", k, "name")), V(("facility_sensitivities", k, "unit")),
                  V(("facility_sensitivities", k, "value"), ",.4f"),
                  V(("facility_sensitivities", k, "sensitivity"), ",.4f"),
                  V(("facility_sensitivities", k, "per_percent"), ",.0f"))
                 for k in range(len(data["facility_sensitivities"])))
    money = data["currency"]
    return Section("Facility sensitivities", (
        Table(("input", "unit", "value", f"d value / d input [{money} per unit]",
               f"value change per percent of the input [{money}]"), rows,
              ("Every facility input, from the same reverse pass as the deltas",), csv="facility_sensitivities.csv"),))


def methods_section(data: dict) -> Section:
    rows = [("mode", V(("mode",))), ("effects", V(("scene_text",))), ("training steps", V(("train_steps",), "d")),
            ("training", V(("train_seconds",), ",.1f", " s")), ("compile", V(("compile_seconds",), ",.1f", " s")),
            ("forward pass", V(("forward_seconds",), ",.3f", " s")),
            ("gradient: every delta and sensitivity", V(("gradient_seconds",), ",.3f", " s")),
            ("gradient over forward", V(("gradient_forward_ratio",), ",.1f", "x")),
            ("intrinsic method", V(("intrinsic_method",))),
            ("everything computed for this report", V(("report_seconds",), ",.1f", " s"))]
    if "max_rel_diff" in data:
        rows.insert(8, ("deltas against central bumps, largest relative difference",
                        V(("max_rel_diff_ppm",), ",.3f", " ppm")))
    if data["lsmc_run"]:
        rows += [("LSMC inventory nodes", V(("lsmc_nodes",), "d")), ("LSMC polynomial degree", V(("lsmc_degree",), "d")),
                 ("LSMC valuation", V(("lsmc_fit_seconds",), ",.1f", " s"))]
    return Section("Methods", (
        Heading("Model"),
        Paragraph(("Daily injection and withdrawal under capacity, rate limits with ratchets, fuel loss, costs and "
                   "discounting (the gas-storage documentation). A neural policy is trained with smooth surrogates of the "
                   "constraints and valued with the exact ones; the intrinsic value is the exact linear program on "
                   "the forward curve; in stochastic mode prices follow a mean-reverting log-normal spot around the "
                   "curve and every value is measured out of sample."),),
        Heading("Settings, timings and checks"),
        Table(("item", "value"), tuple(rows), ("Settings, timings and checks (the appendix of this report)",))))


def sections(data: dict) -> tuple[Section, ...]:
    return (summary_section(data), value_section(data), ladder_section(data), schedule_section(data),
            sensitivity_section(data), methods_section(data))


def _ladder_figure(data: dict):
    import matplotlib.pyplot as plt

    rows = data["monthly_ladder"]
    labels = [r.get("month_name", r["month"].split(" (")[0]) for r in rows]
    positions = np.arange(len(rows))
    series = [("policy", "delta", "#4c78a8"), ("LP envelope", "lp_delta", "#f58518")]
    if rows[0]["lsmc_delta"] is not None:
        series.append(("LSMC pathwise", "lsmc_delta", "#54a24b"))
    width = 0.8 / len(series)
    figure, axis = plt.subplots(figsize=(7.5, 2.8))
    for k, (name, key, colour) in enumerate(series):
        axis.bar(positions + (k - (len(series) - 1) / 2) * width, [r[key] for r in rows], width, label=name, color=colour)
    axis.axhline(0, color="k", lw=0.8)
    axis.set_xticks(positions, labels, rotation=45, fontsize=7)
    axis.set_ylabel(f"{data['energy_unit']} per {data['price_unit']}", fontsize=8)
    axis.legend(fontsize=7, frameon=False)
    figure.tight_layout()
    return figure


def _schedule_figure(data: dict):
    import matplotlib.pyplot as plt

    figure, axis = plt.subplots(figsize=(7.5, 2.9))
    inventory = data["schedule"]["inventory"]
    axis.plot(np.arange(len(inventory)), inventory, label="policy (hard)", color="#4c78a8", lw=1.6)
    axis.plot(np.arange(len(inventory)), data["lp_schedule"]["inventory"], label="intrinsic LP", color="#f58518",
              lw=1.2, ls="--")
    if data.get("lsmc_inventory_mean"):
        axis.plot(np.arange(len(data["lsmc_inventory_mean"])), data["lsmc_inventory_mean"], label="LSMC (mean)",
                  color="#54a24b", lw=1.2)
    axis.set_xlabel("day", fontsize=8)
    axis.set_ylabel(f"inventory [{data['energy_unit']}]", fontsize=8)
    curve = axis.twinx()
    curve.plot(data["forward_curve"], color="#888888", lw=0.9, label="forward curve")
    curve.set_ylabel(f"forward [{data['price_unit']}]", fontsize=8)
    handles = axis.get_legend_handles_labels()[0] + curve.get_legend_handles_labels()[0]
    axis.legend(handles=handles, fontsize=7, frameon=False, loc="upper left")
    figure.tight_layout()
    return figure
