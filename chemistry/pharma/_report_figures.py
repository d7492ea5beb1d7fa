"""The pharma report's figures (matplotlib, drawn from the report's JSON document only): tornado
charts, the design-space map with its contour, NOR and PAR boxes and verification points, and
the probability along the lines through the operating point."""

import numpy as np


CQA_COLOURS = ("#d62728", "#9467bd", "#ff7f0e", "#17becf", "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22")
"""The colour of each CQA's own contour, in the process's order (cycled past eight)."""


def tornado_figure(doc: dict):
    """Per CQA, the change by the full model when each CPP moves to the low and high end of its
    PAR (bars), and the linearised change (ticks), largest first."""
    import matplotlib.pyplot as plt

    study, cpps, specs = doc["sensitivities"], doc["operating_point"], doc["specifications"]
    cpp_names = list(cpps)
    rows = (len(specs) + 2) // 2  # a panel per CQA and one for the legend
    figure, grid = plt.subplots(rows, 2, figsize=(9.0, 1.9 * rows))
    axes = grid.ravel()
    for axis in axes[len(specs):]:
        axis.axis("off")
    for axis, cqa in zip(axes, specs):
        impact, value = doc["summary"]["impact"][cqa], doc["summary"]["cqas"][cqa]["value"]
        lows = np.array([impact[n]["at_par_low"] - value for n in cpp_names])
        highs = np.array([impact[n]["at_par_high"] - value for n in cpp_names])
        linear = np.array([[study["matrix"][cqa][n] * (cpps[n]["par"][k] - cpps[n]["value"]) for k in (0, 1)]
                           for n in cpp_names])
        order = np.argsort(np.abs(highs - lows))
        names = [cpp_names[i] for i in order]
        axis.barh(names, lows[order], color="#4c78a8", label="CPP at the low end of its PAR (full model)")
        axis.barh(names, highs[order], color="#f58518", label="CPP at the high end of its PAR (full model)")
        axis.scatter(linear[order].ravel(), np.repeat(np.arange(len(names)), 2), marker="|", s=90, color="k",
                     zorder=3, label="linearised")
        axis.axvline(0, color="k", lw=0.8)
        axis.set_title(f"{cqa} [{specs[cqa]['unit']}], spec {specs[cqa]['spec']}", fontsize=8.5, loc="left")
        axis.tick_params(labelsize=7.5)
    handles, labels = axes[0].get_legend_handles_labels()
    axes[-1].legend(handles, labels, fontsize=8, loc="center", frameon=False)
    figure.tight_layout()
    return figure


def design_space_figure(doc: dict):
    """P(all specs) on the grid, the contour at the level (and each CQA's own), NOR and PAR
    boxes, the operating point and the Monte Carlo verification points."""
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
    from matplotlib.patches import Rectangle

    space, cpps = doc["design_space"], doc["operating_point"]
    x, y, level = space["x"], space["y"], space["level"]
    xs, ys = np.array(space["x_values"]), np.array(space["y_values"])
    probability = np.array(space["probability"])
    figure, axis = plt.subplots(figsize=(6.4, 4.9))
    # x is the CPP of the first index: plot it on the horizontal axis.
    mesh = axis.contourf(xs, ys, probability.T, levels=np.linspace(0, 1, 21), cmap="RdYlGn", vmin=0, vmax=1)
    handles = []
    # The edge first, wide and grey-black, each CQA's own contour over it, narrower and labelled
    # with its name on the line: where a CQA's line runs along the edge, that CQA sets it.
    if probability.min() < level < probability.max():
        axis.contour(xs, ys, probability.T, levels=[level], colors="#222222", linewidths=4.0, alpha=0.55, zorder=2)
    handles.insert(0, Line2D([], [], color="#222222", lw=4.0, alpha=0.55,
                             label=f"P(all specs) = {level:g}: edge of the design space"))
    for k, cqa in enumerate(doc["specifications"]):
        by_cqa, colour = np.array(space["probability_by_cqa"][cqa]).T, CQA_COLOURS[k % len(CQA_COLOURS)]
        if by_cqa.min() < level < by_cqa.max():
            lines = axis.contour(xs, ys, by_cqa, levels=[level], colors=[colour], linewidths=1.6, linestyles="--",
                                 zorder=3)
            axis.clabel(lines, fmt={level: cqa}, fontsize=7, inline=True, colors=[colour])
            handles.append(Line2D([], [], color=colour, ls="--", lw=1.6, label=f"P({cqa} in spec) = {level:g}"))
    for key, style in (("nor", dict(ec="#08306b", lw=1.8, ls="-")), ("par", dict(ec="#555555", lw=1.2, ls=":"))):
        (x0, x1), (y0, y1) = cpps[x][key], cpps[y][key]
        axis.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, **style))
        handles.append(Line2D([], [], color=style["ec"], ls=style["ls"], lw=style["lw"], label=key.upper()))
    points = space["verification"]["points"]
    axis.scatter([p["x"] for p in points], [p["y"] for p in points], s=36, facecolors="white", edgecolors="k",
                 zorder=5)
    handles.append(Line2D([], [], marker="o", ls="", mfc="white", mec="k", label="full Monte Carlo check"))
    axis.scatter([cpps[x]["value"]], [cpps[y]["value"]], marker="*", s=160, color="#08306b", zorder=6)
    handles.append(Line2D([], [], marker="*", ls="", color="#08306b", ms=11, label="operating point"))
    axis.set_xlabel(f"{x} [{cpps[x]['unit']}]")
    axis.set_ylabel(f"{y} [{cpps[y]['unit']}]")
    axis.set_xlim(xs[0], xs[-1])
    axis.set_ylim(ys[0], ys[-1])
    figure.colorbar(mesh, ax=axis, label="P(every CQA within its specification)", shrink=0.9, ticks=np.linspace(0, 1, 6))
    axis.legend(handles=handles, fontsize=7, loc="upper left", bbox_to_anchor=(0.0, -0.13), ncol=2, frameon=False)
    figure.tight_layout()
    return figure


def profile_figure(doc: dict):
    """P(all specs) along the grid lines through the operating point, with the level, the NOR
    and PAR, and the edges of failure."""
    import matplotlib.pyplot as plt

    space, cpps = doc["design_space"], doc["operating_point"]
    x, y, level = space["x"], space["y"], space["level"]
    probability = np.array(space["probability"])
    xs, ys = np.array(space["x_values"]), np.array(space["y_values"])
    i = int(np.argmin(np.abs(xs - cpps[x]["value"])))
    j = int(np.argmin(np.abs(ys - cpps[y]["value"])))
    figure, axes = plt.subplots(1, 2, figsize=(7.2, 2.5), sharey=True)
    for axis, name, values, line in ((axes[0], x, xs, probability[:, j]), (axes[1], y, ys, probability[i, :])):
        axis.axvspan(*cpps[name]["nor"], color="#c6dbef", alpha=0.7, lw=0, label="NOR")
        axis.plot(values, line, color="k", lw=1.5, marker=".", ms=4, label="P(all specs)")
        axis.axhline(level, color="#b2182b", lw=1, ls="--", label=f"level {level:g}")
        for edge in ("edge_low", "edge_high"):
            value = space["edges"][name][edge]
            if value is not None:
                axis.axvline(value, color="#b2182b", lw=1)
        axis.axvline(cpps[name]["value"], color="#08306b", lw=1, ls=":")
        axis.set_xlim(*cpps[name]["par"])
        axis.set_xlabel(f"{name} [{cpps[name]['unit']}] (PAR shown)", fontsize=8)
        axis.tick_params(labelsize=7.5)
    axes[0].set_ylabel("P(all specs)", fontsize=8)
    axes[0].set_ylim(-0.02, 1.02)
    axes[1].legend(fontsize=6.5, loc="lower left", frameon=False)
    figure.tight_layout()
    return figure
