"""`snapo report pharma --out DIR`: the regulatory sensitivity report as report.html (self-contained:
inline base64 PNG figures), report.pdf (same sections), sensitivities.csv and report.json, each
written atomically. Every number in the HTML is taken from the JSON."""

import base64
import csv
import datetime
import hashlib
import html
import io
import json
import pathlib
import platform
import subprocess
from importlib.metadata import PackageNotFoundError, version

import numpy as np

from snapo_ode import atomic_write_bytes, json_bytes, publish_directory

from ._chain import DEFAULT_MECHANISM, PharmaChain
from ._design_space import design_space
from ._parameters import PHYSICAL_NAMES, CPPs
from ._ranges import CPP_NAMES, CPP_RANGES, CQA_NAMES, CQA_SPECS
from ._study import REFERENCE, sensitivity_study
from ._verification import cantera_check, stiffness_ratio

PACKAGES = ("snapo-ode", "jax", "jaxlib", "diffrax", "equinox", "optax", "optimistix", "lineax", "cantera",
            "numpy", "scipy", "matplotlib")
SECTIONS = ("Critical process parameters", "Critical quality attributes", "Nominal CQAs", "Sensitivity matrix",
            "Tornado charts", "Design space", "Verification", "Solver settings", "Timings", "Provenance")


def _sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def provenance(chain: PharmaChain, cpps: CPPs, physical, mechanism_path) -> dict:
    """Package versions, the git commit (and whether the tree was dirty), a SHA-256 of every
    input, and the UTC timestamp."""
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            versions[name] = None
    root = pathlib.Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True,
                                check=True).stdout.strip()
        dirty = bool(subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                                    capture_output=True, text=True, check=True).stdout.strip())
    except (OSError, subprocess.CalledProcessError):
        commit, dirty = None, None
    physical_values = {name: float(getattr(physical, name)) for name in PHYSICAL_NAMES}
    return {
        "packages": versions, "python": platform.python_version(), "git_commit": commit, "git_dirty": dirty,
        "input_sha256": {
            "mechanism": _sha256(pathlib.Path(mechanism_path).read_bytes()),
            "cpps": _sha256(json.dumps(cpps.as_dict(), sort_keys=True).encode()),
            "physical_parameters": _sha256(json.dumps(physical_values, sort_keys=True).encode()),
            "solver": _sha256(json.dumps(chain.solver.as_dict(), sort_keys=True).encode()),
            "effects": _sha256(json.dumps(sorted(chain.scene.active)).encode()),
        },
        "timestamp_utc": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
    }


def build_report(chain: PharmaChain, cpps: CPPs, *, points: int = 5, samples: int = 32, repeats: int = 5,
                 mechanism_path=DEFAULT_MECHANISM) -> dict:
    """Every number of the report, as a JSON-ready dict."""
    inputs = chain.inputs(cpps)
    result = sensitivity_study(chain, cpps, repeats=repeats)
    study = result.to_json()
    tight = chain.with_solver(REFERENCE)
    cantera = cantera_check(tight, cpps, inputs.physical, mechanism_path)
    space = design_space(chain, cpps, points=points, samples=samples).to_json()
    return {
        "cpps": [{"name": r.name, "unit": r.unit, "value": study["cpps"][r.name], "nominal": r.nominal,
                  "nor": list(r.nor), "par": list(r.par), "description": r.description} for r in CPP_RANGES],
        "cqa_specs": [{"name": s.name, "unit": s.unit, "low": None if np.isinf(s.low) else s.low,
                       "high": None if np.isinf(s.high) else s.high, "spec": s.text(),
                       "description": s.description} for s in CQA_SPECS],
        "warnings": study["warnings"],
        "sensitivities": study,
        "design_space": space,
        "verification": {
            "max_rel_diff_fd": study["max_rel_diff_fd"],
            "max_rel_diff_fd_parameters": study["max_rel_diff_fd_parameters"],
            "reference_rel_error": study["reference_rel_error"],
            "cantera_rates_of_progress": cantera.rates_of_progress,
            "cantera_net_production": cantera.net_production,
            "cantera_r1_amounts": cantera.r1_amounts,
            "cantera_r1_temperature": cantera.r1_temperature,
            "r1_stiffness_ratio": stiffness_ratio(chain, cpps, inputs.physical),
        },
        "solver": chain.solver.as_dict(),
        "timings": {"seconds_median": study["seconds_median"], "compile_seconds": study["compile_seconds"],
                    "mode": study["mode"], "passes": study["passes"]},
        "provenance": provenance(chain, cpps, inputs.physical, mechanism_path),
    }


def _tornado_figure(report):
    import matplotlib.pyplot as plt

    study = report["sensitivities"]
    figure, axes = plt.subplots(len(CQA_NAMES), 1, figsize=(7, 2.0 * len(CQA_NAMES)))
    for axis, cqa in zip(axes, CQA_NAMES, strict=True):
        lows, highs = [], []
        for r in CPP_RANGES:
            slope = study["matrix"][cqa][r.name]
            lows.append(slope * (r.par[0] - study["cpps"][r.name]))
            highs.append(slope * (r.par[1] - study["cpps"][r.name]))
        order = np.argsort(np.abs(np.array(highs) - np.array(lows)))
        names = [CPP_NAMES[i] for i in order]
        axis.barh(names, [lows[i] for i in order], color="tab:blue", label="CPP at PAR low")
        axis.barh(names, [highs[i] for i in order], color="tab:orange", label="CPP at PAR high")
        axis.axvline(0, color="k", lw=0.8)
        unit = next(s.unit for s in CQA_SPECS if s.name == cqa)
        axis.set_title(f"{cqa}: linearised change over the proven acceptable range [{unit}]", fontsize=9)
        axis.tick_params(labelsize=8)
    axes[0].legend(fontsize=7, loc="lower right")
    figure.tight_layout()
    return figure


def _design_figure(report):
    import matplotlib.pyplot as plt

    space = report["design_space"]
    figure, axes = plt.subplots(1, 2, figsize=(9, 3.8), sharey=True)
    extent = [space["y_values"][0], space["y_values"][-1], space["x_values"][0], space["x_values"][-1]]
    for axis, key, title in zip(axes, ("probability_mc", "probability_linear"),
                                ("Monte Carlo", "linearised (sensitivities)"), strict=True):
        image = axis.imshow(np.array(space[key]), origin="lower", extent=extent, aspect="auto", vmin=0, vmax=1,
                            cmap="viridis")
        axis.set_title(f"P(all specs met), {title}", fontsize=9)
        axis.set_xlabel(f"{space['y']} [K]")
    axes[0].set_ylabel(f"{space['x']} [K]")
    figure.colorbar(image, ax=axes, shrink=0.8)
    return figure


def _png(figure) -> str:
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=90)
    return base64.b64encode(buffer.getvalue()).decode()


def _number(value, key: str) -> str:
    return f'<td class="num" data-key="{html.escape(key)}">{value:.6g}</td>'


def _table(header, rows) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = "".join(f"<tr>{''.join(rows_cells)}</tr>" for rows_cells in rows)
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _text(value) -> str:
    return f"<td>{html.escape(str(value))}</td>"


def render_html(report: dict, tornado_png: str, design_png: str) -> str:
    """The report as one self-contained HTML page."""
    study = report["sensitivities"]
    parts = ["<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
             "<title>Pharma chain: ICH Q8 sensitivity report</title>",
             "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse;"
             "margin:8px 0}td,th{border:1px solid #999;padding:3px 6px;font-size:13px}td.num{text-align:right}"
             ".warn{color:#a00}</style></head><body>",
             "<h1>API manufacturing chain: ICH Q8 sensitivity report</h1>"]
    parts.extend(f'<p class="warn">Warning: {html.escape(w)}</p>' for w in report["warnings"])
    parts.append(f"<h2>{SECTIONS[0]}</h2>")
    parts.append(_table(["CPP", "unit", "value", "nominal", "NOR low", "NOR high", "PAR low", "PAR high", "description"], [
        [_text(c["name"]), _text(c["unit"]), _number(c["value"], f"cpps.{c['name']}.value"),
         _number(c["nominal"], f"cpps.{c['name']}.nominal"), _number(c["nor"][0], f"cpps.{c['name']}.nor.0"),
         _number(c["nor"][1], f"cpps.{c['name']}.nor.1"), _number(c["par"][0], f"cpps.{c['name']}.par.0"),
         _number(c["par"][1], f"cpps.{c['name']}.par.1"), _text(c["description"])] for c in report["cpps"]]))
    parts.append(f"<h2>{SECTIONS[1]}</h2>")
    parts.append(_table(["CQA", "unit", "specification", "description"], [
        [_text(s["name"]), _text(s["unit"]), _text(s["spec"]), _text(s["description"])] for s in report["cqa_specs"]]))
    parts.append(f"<h2>{SECTIONS[2]}</h2>")
    parts.append(_table(["CQA", "value", "specification"], [
        [_text(s["name"]), _number(study["cqas"][s["name"]], f"sensitivities.cqas.{s['name']}"), _text(s["spec"])]
        for s in report["cqa_specs"]]))
    parts.append(f"<h2>{SECTIONS[3]}</h2><p>Absolute d CQA / d CPP (CQA units per CPP unit):</p>")
    for key, caption in (("matrix", None), ("normalized", "Normalised d ln CQA / d ln CPP:")):
        if caption:
            parts.append(f"<p>{caption}</p>")
        parts.append(_table(["CQA", *CPP_NAMES], [
            [_text(cqa), *(_number(study[key][cqa][cpp], f"sensitivities.{key}.{cqa}.{cpp}") for cpp in CPP_NAMES)]
            for cqa in CQA_NAMES]))
    parts.append(f"<h2>{SECTIONS[4]}</h2>")
    parts.append(f'<img alt="tornado charts" src="data:image/png;base64,{tornado_png}">')
    space = report["design_space"]
    parts.append(f"<h2>{SECTIONS[5]}</h2><p>Probability that every CQA meets its specification, "
                 f"{space['samples']} draws of the five rate constants (sigma of ln k = {space['sigma_log_rate']:g}), "
                 f"other CPPs at their values above. Largest |Monte Carlo - linearised| = "
                 f"{space['max_abs_difference']:.6g}.</p>")
    parts.append(f'<img alt="design space" src="data:image/png;base64,{design_png}">')
    parts.append(_table(["CPP", f"range with P >= {space['confidence']:g} (other at nominal)"], [
        [_text(name), _text("none" if interval is None else f"{interval[0]:.6g} - {interval[1]:.6g}")]
        for name, interval in space["acceptable_ranges"].items()]))
    verification = report["verification"]
    parts.append(f"<h2>{SECTIONS[6]}</h2>")
    parts.append(_table(["check", "value"], [[_text(name), _number(value, f"verification.{name}")]
                                              for name, value in verification.items()]))
    parts.append(f"<h2>{SECTIONS[7]}</h2>")
    parts.append(_table(["setting", "value"], [[_text(k), _text(v)] for k, v in report["solver"].items()]))
    parts.append(f"<h2>{SECTIONS[8]}</h2>")
    timings = report["timings"]
    parts.append(_table(["what", "value"], [
        [_text("mode"), _text(timings["mode"])], [_text("passes"), _text(timings["passes"])],
        [_text("seconds_median"), _number(timings["seconds_median"], "timings.seconds_median")],
        [_text("compile_seconds"), _number(timings["compile_seconds"], "timings.compile_seconds")]]))
    provenance = report["provenance"]
    parts.append(f"<h2>{SECTIONS[9]}</h2>")
    rows = [[_text(k), _text(v)] for k, v in provenance["packages"].items()]
    rows += [[_text(k), _text(provenance[k])] for k in ("python", "git_commit", "git_dirty", "timestamp_utc")]
    rows += [[_text(f"sha256 {k}"), _text(v)] for k, v in provenance["input_sha256"].items()]
    parts.append(_table(["item", "value"], rows))
    parts.append("</body></html>")
    return "\n".join(parts)


def _pdf(report: dict, tornado_figure, design_figure) -> bytes:
    """The same sections as the HTML: tables as text pages, then the figures."""
    import matplotlib.pyplot as plt
    from matplotlib.backends.backend_pdf import PdfPages

    study, verification = report["sensitivities"], report["verification"]
    blocks = {
        SECTIONS[0]: [f"{c['name']}: {c['value']:.6g} {c['unit']} (NOR {c['nor'][0]:g}-{c['nor'][1]:g}, "
                      f"PAR {c['par'][0]:g}-{c['par'][1]:g})" for c in report["cpps"]],
        SECTIONS[1]: [f"{s['name']}: {s['spec']}" for s in report["cqa_specs"]],
        SECTIONS[2]: [f"{name}: {value:.6g}" for name, value in study["cqas"].items()],
        # One line per pair: five CPPs on one line ran off the page.
        SECTIONS[3]: [f"d {cqa} / d {cpp}: {study['matrix'][cqa][cpp]:.4g} "
                      f"(normalised {study['normalized'][cqa][cpp]:.3g})"
                      for cqa in CQA_NAMES for cpp in CPP_NAMES],
        SECTIONS[6]: [f"{k}: {v:.6g}" for k, v in verification.items()],
        SECTIONS[7]: [f"{k}: {v}" for k, v in report["solver"].items()],
        SECTIONS[8]: [f"{k}: {v}" for k, v in report["timings"].items()],
        SECTIONS[9]: [f"{k}: {v}" for k, v in report["provenance"]["packages"].items()]
        + [f"git commit: {report['provenance']['git_commit']}", f"timestamp: {report['provenance']['timestamp_utc']}"]
        + [f"sha256 {k}: {v[:16]}..." for k, v in report["provenance"]["input_sha256"].items()],
    }
    buffer = io.BytesIO()
    with PdfPages(buffer) as pdf:
        figure = plt.figure(figsize=(8.27, 11.69))
        y = 0.97
        figure.text(0.05, y, "API manufacturing chain: ICH Q8 sensitivity report", fontsize=13, weight="bold")
        def room_for(height):
            nonlocal figure, y
            if y - height < 0.05:
                pdf.savefig(figure)
                plt.close(figure)
                figure, y = plt.figure(figsize=(8.27, 11.69)), 0.97
            y -= height

        for title, lines in blocks.items():
            room_for(0.03 + 0.018)  # a title never ends a page
            y += 0.018
            figure.text(0.05, y, title, fontsize=11, weight="bold")
            for line in lines:
                room_for(0.018)
                figure.text(0.07, y, line, fontsize=6.5, family="monospace")
        pdf.savefig(figure)
        plt.close(figure)
        for title, fig in ((SECTIONS[4], tornado_figure), (SECTIONS[5], design_figure)):
            fig.suptitle(title, fontsize=11)
            pdf.savefig(fig)
            plt.close(fig)
    return buffer.getvalue()


def write_report(out: pathlib.Path, report: dict, json_path: pathlib.Path | None = None) -> list[pathlib.Path]:
    """Write report.json, sensitivities.csv, report.html and report.pdf as the directory `out`,
    one set (`snapo_ode.publish_directory`: the old report or the new one, never a mix), and the
    JSON also to `json_path` when it lies elsewhere."""
    import matplotlib

    matplotlib.use("Agg")
    tornado, design = _tornado_figure(report), _design_figure(report)
    tornado_png, design_png = _png(tornado), _png(design)
    study = report["sensitivities"]
    buffer = io.StringIO()
    writer = csv.writer(buffer)
    writer.writerow(["cqa", "input", "kind", "sensitivity", "normalized"])
    for cqa in CQA_NAMES:
        for cpp in CPP_NAMES:
            writer.writerow([cqa, cpp, "cpp", repr(study["matrix"][cqa][cpp]), repr(study["normalized"][cqa][cpp])])
        for name, value in study["parameter_sensitivities"][cqa].items():
            writer.writerow([cqa, name, "parameter", repr(value),
                             repr(study["parameter_sensitivities_normalized"][cqa][name])])
    report_json = json_bytes(report)
    written = publish_directory(out, {
        "report.json": report_json,
        "sensitivities.csv": buffer.getvalue().encode("utf-8"),
        "report.html": render_html(report, tornado_png, design_png).encode("utf-8"),
        "report.pdf": _pdf(report, tornado, design),
    })
    if json_path is not None and pathlib.Path(json_path).resolve() != (pathlib.Path(out) / "report.json").resolve():
        written.append(atomic_write_bytes(json_path, report_json))
    return written
