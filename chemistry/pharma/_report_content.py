"""What the pharma report shows, in reading order: an executive summary, the process and its
specifications, the nominal CQAs, every unit's mass balance, the sensitivities, the design space and the methods. Every
number is a `Value` (a path into the report's JSON); the core renders and prints it."""

from snapo_ode import Bullets, Figure, Heading, Highlights, Paragraph, Section, Table, Value

from ._report_figures import design_space_figure, profile_figure, tornado_figure
from ._study import REFERENCE_METHODS

V = Value
IMPACT_WORDS = {"high": "high: can leave the spec within the PAR", "medium": "medium", "low": "low"}


def _range(path, fmt=".5g") -> tuple:
    return (V((*path, 0), fmt), "\u00a0\u2013\u00a0", V((*path, 1), fmt))


def _names(data: dict) -> tuple[list, list]:
    """The process's CPP and CQA names, in its order (the data's keys)."""
    return list(data["operating_point"]), list(data["specifications"])


def executive_summary(data: dict) -> Section:
    space, summary = data["design_space"], data["summary"]
    cpp_names, cqa_names = _names(data)
    x, y = space["x"], space["y"]
    ds = ("design_space",)
    findings = [Paragraph((
        "At the operating point every CQA meets its specification: ", V(("summary", "all_specs_met")),
        ". The CQA nearest its limit is ", V(("summary", "closest_cqa")), ", at ",
        V(("summary", "cqas", summary["closest_cqa"], "relative_margin"), ".1%"), " of the limit from it. "
        "Under the stated uncertainty of the rate constants, the probability that every CQA is within its "
        "specification is ", V((*ds, "operating_probability"), ".2%"), " at the operating point and at least ",
        V((*ds, "nor_min_probability"), ".2%"), " over the normal operating ranges of ", x, " and ", y,
        "; the design space (probability at least ", V((*ds, "level"), "g"), ") covers ",
        V((*ds, "fraction_meeting_level"), ".0%"), " of their proven acceptable ranges."), "finding")]
    cards = Highlights((
        ("P(all specs) at the operating point", V((*ds, "operating_probability"), ".2%"), ("surrogate map",)),
        ("Least P(all specs) over the NOR box", V((*ds, "nor_min_probability"), ".2%"),
         ("level ", V((*ds, "level"), "g"))),
        ("Map against full Monte Carlo", V((*ds, "verification", "max_difference_over_se"), ".2f", " standard errors"),
         ("largest difference in standard errors, over ", V((*ds, "verification", "samples"), "d"), " draws at each of ",
          V(("design_space", "verification_count"), "d"), " points")),
        ("Sensitivities against central differences", V(("verification_digits", "max_rel_diff_fd"), ".1f", " digits"),
         ("significant digits in common, CPP block",)),
        ("Reactors against Cantera", V(("verification_digits", "cantera_reactors_max_amounts"), ".1f", " digits"),
         ("of the outlet amounts, the worst of ", V(("process", "reactor_count"), "d"), " reactors")),
        ("Solver against the reference solver", V(("verification_digits", "reference_rel_error"), ".1f", " digits"),
         ("sensitivities",)),
    ))
    impact_rows = tuple((cqa, *((V(("summary", "impact", cqa, cpp, "grade_full_model")), " (",
                                 V(("summary", "impact", cqa, cpp, "fraction_of_margin_full_model"), ".2f"),
                                 "); linearised ", V(("summary", "impact", cqa, cpp, "grade")), " (",
                                 V(("summary", "impact", cqa, cpp, "fraction_of_margin"), ".2f"), ")")
                                for cpp in cpp_names)) for cqa in cqa_names)
    impact = Table(("CQA", *cpp_names), impact_rows, (
        "Which CPPs matter for which CQA: the largest change of the CQA when the CPP moves to either end of its "
        "PAR, the others at the operating point, by the full model (first) and linearised from the sensitivity "
        "(second), as a fraction of the CQA's margin to its specification (high from ",
        V(("summary", "impact_thresholds", "high"), "g"), ", medium from ",
        V(("summary", "impact_thresholds", "medium"), "g"), "). The full model's grade is the one to act on: "
        "where a CQA is curved over the PAR the linearised one understates it"))
    mapped_note = Paragraph(("What was mapped: the design space is over ", x, " and ", y, " (",
                        V(("mapped", "count"), "d"), " of the ", V(("mapped", "of"), "d"), " CPPs); ",
                        *_held(data), ". Their own ranges are covered by the criticality table above, by the full "
                        "model at each end of the PAR, one CPP at a time."), "note")
    ranges = []
    for name in cpp_names:
        path = ("operating_point", name)
        mapped = name in (x, y)
        edges = ("design_space", "edges", name)
        ranges.append((name, _range((*path, "nor")), _range((*path, "par")),
                       _range((*edges, "interval")) if mapped and space["edges"][name]["interval"] else "not mapped",
                       V((*edges, "edge_low"), ".5g") if mapped else "-", V((*edges, "edge_high"), ".5g") if mapped else "-",
                       V((*edges, "margin_below_nor"), ",.3f") if mapped else "-",
                       V((*edges, "margin_above_nor"), ",.3f") if mapped else "-"))
    ranges_table = Table(("CPP", "NOR", "PAR", "design space along the line", "edge below", "edge above",
                          "NOR to edge below", "NOR to edge above"), tuple(ranges), (
        "Proven acceptable ranges and the margin to the edge of failure (P(all specs) = level) along the grid lines "
        "through the operating point; n/a: no edge inside the PAR",))
    return Section("Executive summary", (cards, *findings, mapped_note, impact, ranges_table, Paragraph((
        "Verification: the map agrees with full Monte Carlo at every verification point within one standard "
        "error: ", V((*ds, "verification", "all_within_se")), ". See the design space and the methods.",), "note")))


def _held(data: dict) -> tuple:
    """The CPPs the design space holds, each at its operating value with its unit."""
    held = list(data["mapped"]["held"])
    if not held:
        return ("no other CPP",)
    out = ["the others are held at the operating point: "]
    for k, name in enumerate(held):
        out += [name, " ", V(("mapped", "held", name), ",.6g", " " + data["operating_point"][name]["unit"])]
        out.append(", " if k < len(held) - 1 else "")
    return tuple(item for item in out if item != "")


def process_section(data: dict) -> Section:
    cpp_names, cqa_names = _names(data)
    cpps = tuple((name, V(("operating_point", name, "unit")), V(("operating_point", name, "value"), ".6g"),
                  V(("operating_point", name, "nominal"), ".6g"), _range(("operating_point", name, "nor"), ".6g"),
                  _range(("operating_point", name, "par"), ".6g"), V(("operating_point", name, "description")))
                 for name in cpp_names)
    specs = tuple((name, V(("specifications", name, "unit")), V(("specifications", name, "spec")),
                   V(("specifications", name, "description"))) for name in cqa_names)
    return Section("Process parameters and specifications", (
        Table(("CPP", "unit", "value", "nominal", "NOR", "PAR", "description"), cpps,
              ("Critical process parameters (CPPs) at the operating point",)),
        Table(("CQA", "unit", "specification", "description"), specs, ("Critical quality attributes (CQAs)",))))


def nominal_section(data: dict) -> Section:
    _, cqa_names = _names(data)
    rows = tuple((name, V(("summary", "cqas", name, "value"), ",.4f", " " + data["specifications"][name]["unit"]),
                  V(("specifications", name, "spec")),
                  V(("summary", "cqas", name, "margin"), ",.4f", " " + data["specifications"][name]["unit"]), V(("summary", "cqas", name, "relative_margin"), ".1%"),
                  V(("summary", "cqas", name, "meets"))) for name in cqa_names)
    return Section("Nominal CQAs", (Table(("CQA", "value", "specification", "margin to the limit",
                                           "margin, of the limit", "meets"), rows,
                                          ("The CQAs at the operating point, nominal kinetics",)),))


def balance_section(data: dict) -> Section:
    rows = tuple((V(("mass_balances", k, "unit")), V(("mass_balances", k, "type")), V(("mass_balances", k, "conserved")),
                  V(("mass_balances", k, "residual_digits"), ".1f", " digits")) for k in range(len(data["mass_balances"])))
    return Section("Mass balances", (
        Table(("unit", "type", "what the balance holds", "balance closed to"), rows,
              ("Every unit's mass balance at the operating point, as the significant digits to which in and out "
               "agree: at round-off (sixteen, a double's) the unit makes and loses nothing it should not",),
              csv="mass_balances.csv"),))


def sensitivity_section(data: dict) -> Section:
    cpp_names, cqa_names = _names(data)

    ends = tuple((cqa, *(cell for cpp in cpp_names for cell in (
        V(("summary", "impact", cqa, cpp, "at_par_low"), ",.3f"), V(("summary", "impact", cqa, cpp, "at_par_high"), ",.3f"))))
        for cqa in cqa_names)
    return Section("Sensitivities", (
        Table(("CQA", *(f"{cpp}: {end}" for cpp in cpp_names for end in ("PAR low", "PAR high"))), ends,
              ("Each CQA by the full model with one CPP at an end of its PAR, the others at the operating point, in "
               "the CQA's unit (the specifications' table)",)),
        Table(("CQA", *cpp_names), tuple((cqa, *(V(("sensitivities", "normalized", cqa, cpp), "+,.3f") for cpp in cpp_names))
                                         for cqa in cqa_names),
              ("Normalised sensitivities d ln CQA / d ln CPP, from ", V(("sensitivities", "passes"), "d"), " ",
               V(("sensitivities", "mode")), "-mode passes: the percent change of the CQA per percent of the CPP",)),
        Figure.from_matplotlib(tornado_figure(data), ("Tornado charts: the change of each CQA by the full model when "
                                                      "one CPP moves to either end of its PAR, the others at the "
                                                      "operating point; ticks: the linearised change",),
                               "tornado charts", width="100%"),
        Paragraph(("Every CQA's absolute sensitivity d CQA / d CPP, and to every kinetic and physical parameter, is "
                   "in sensitivities.csv (absolute and normalised).",), "note")))


def design_space_section(data: dict) -> Section:
    space = data["design_space"]
    ds = ("design_space",)
    rows = tuple((V((*ds, "verification", "points", k, "x"), ".5g"), V((*ds, "verification", "points", k, "y"), ".5g"),
                  V((*ds, "verification", "points", k, "probability_map"), ".4f"),
                  V((*ds, "verification", "points", k, "probability_surrogate"), ".4f"),
                  V((*ds, "verification", "points", k, "probability_mc"), ".4f"),
                  V((*ds, "verification", "points", k, "se_mc"), ".4f"),
                  V((*ds, "verification", "points", k, "disagreeing_draws"), "d"),
                  V((*ds, "verification", "points", k, "within_se")))
                 for k in range(len(space["verification"]["points"])))
    return Section("Design space", (
        Paragraph(("The probability that every CQA meets its specification when the uncertain rate constants vary "
                   "(log-normal, standard deviation of ln k ", V((*ds, "sigma_log_rate"), "g"), "), on a grid of ",
                   V((*ds, "grid_size"), "d"), " by ", V((*ds, "grid_size"), "d"), " points over the PARs of ",
                   V((*ds, "x")), " and ", V((*ds, "y")), ", the other CPPs at the operating point. The wide grey "
                   "contour is the edge of the design space at probability ", V((*ds, "level"), "g"), "; each CQA's "
                   "own dashed contour, where that CQA alone reaches that probability, is drawn over it and labelled "
                   "with the CQA's name, so the CQA that sets each part of the edge can be read off."),),
        Figure.from_matplotlib(design_space_figure(data), ("Design space: P(all specs) from the surrogate (",
                                                             V((*ds, "surrogate_samples"), "d"), " draws), "
                                                             "NOR and PAR boxes, and the points checked by full Monte "
                                                             "Carlo",), "design-space map", width="78%"),
        Figure.from_matplotlib(profile_figure(data), ("P(all specs) along the grid lines through the operating point; "
                                                      "vertical red lines: the edges of failure",),
                               "probability along the lines through the operating point", width="90%"),
        Heading("Verification by full Monte Carlo"),
        Paragraph(("The full model was run at ", V((*ds, "verification_count"), "d"), " grid points (the operating "
                   "point, then points along the edge of failure spread over the map) on the first ",
                   V((*ds, "verification", "samples"), "d"), " of the surrogate's draws. The surrogate on the same "
                   "draws differs by at most ", V((*ds, "verification", "max_abs_difference"), ".4f"), ", which is ",
                   V((*ds, "verification", "max_difference_over_se"), ".2f"), " standard errors of the Monte Carlo "
                   "estimate; the map, on all its draws, is within ",
                   V((*ds, "verification", "max_abs_map_minus_mc_over_se"), ".2f"), " standard errors of it."),),
        Table((space["x"], space["y"], "map", "surrogate, same draws", "full Monte Carlo", "standard error",
               "draws classified differently", "within one standard error"), rows,
              ("Map and surrogate against the full model",), csv="design_space_verification.csv"),
        Paragraph(("Standard error: ", V((*ds, "verification", "se_convention")), "."), "note")))


def methods_section(data: dict) -> Section:
    ds, digits = ("design_space",), ("verification_digits",)
    checks = Table(("check", "significant digits in common"), (
        ("sensitivities (CPP block) against Richardson central differences", V((*digits, "max_rel_diff_fd"), ".1f")),
        ("every parameter sensitivity against central differences", V((*digits, "max_rel_diff_fd_parameters"), ".1f")),
        (f"sensitivities against the reference solver ({REFERENCE_METHODS}, tight tolerances)",
         V((*digits, "reference_rel_error"), ".1f")),
        ("every parameter sensitivity against the reference solver", V((*digits, "reference_rel_error_parameters"), ".1f")),
        ("CQAs against the reference solver", V((*digits, "reference_cqa_rel_error"), ".1f")),
        ("rates of progress against Cantera", V((*digits, "cantera_rates_of_progress"), ".1f")),
        ("net production rates against Cantera", V((*digits, "cantera_net_production"), ".1f")),
        *((f"{name}: outlet amounts against Cantera's reactor fed the same stream",
           V((*digits, "cantera_reactors", name, "amounts"), ".1f")) for name in data["verification"]["cantera_reactors"]),
        *((f"{name}: outlet temperature against Cantera's reactor",
           V((*digits, "cantera_reactors", name, "temperature"), ".1f"))
          for name in data["verification"]["cantera_reactors"]),
        ("first reactor's stiffness ratio at the feed (a ratio, not digits)",
         V(("verification", "r1_stiffness_ratio"), ",.0f"))),
        ("Verification evidence: the significant digits each pair of results shares (the largest relative difference "
         "d as -log10 d; sixteen is a double's round-off)",))
    return Section("Methods", (
        Heading("Model"),
        Paragraph(("The process ", V(("process", "units")), " (", V(("process", "description")), ") is one "
                   "differentiable program: each unit is an ODE solve or an algebraic step, the kinetics are read "
                   "from the Cantera YAML mechanism and the process from its file, whose SHA-256 are under "
                   "Provenance. The CQAs are those of the product as the last unit gives it."),),
        Heading("Kinetic parameters: origin, assumptions and limitations"),
        Bullets((("Origin: every rate constant, temperature exponent and activation energy is the mechanism file's (",
                  V(("model", "mechanism_file")), "), as its authors state them; this report fits none of them to "
                  "plant or laboratory data."),
                 ("Assumptions: the reactors are ideal (plug flow or perfectly mixed), the jackets hold the stated "
                  "temperatures, the crystallizer follows its population balance, the dryer its drying law; the "
                  "uncertain inputs (", V((*ds, "uncertain_text")), ") are independent and log-normal with standard "
                  "deviation of ln k ", V((*ds, "sigma_log_rate"), "g"), "."),
                 ("Validation: numerical only (the solver against a reference solver, every reactor against "
                  "Cantera's, the sensitivities against central differences, the map against full Monte Carlo, "
                  "below). The model is not validated here against batch data: before the design space is filed, "
                  "its predictions should be compared with the development batches.",),
                 ("Limitations: the model holds inside the CPPs' physical limits (a solvent's freezing and boiling "
                  "points); outside the PARs the map is an extrapolation; effects the process file does not name "
                  "(fouling, scale-up mixing, impurities in the feed) are not modelled.",))),
        Heading("Sensitivities"),
        Paragraph(("The Jacobian of the CQAs with respect to every input (CPPs, rate parameters, physical "
                   "parameters) is taken in ", V(("sensitivities", "mode")), " mode, ",
                   V(("sensitivities", "passes"), "d"), " passes, and checked against Richardson-extrapolated "
                   "central differences at tight tolerances and against a reference solve with a different method. "
                   "Criticality is graded by the full model at the ends of each PAR (the other CPPs at the operating "
                   "point), beside the linearised grade."),),
        Heading("Design space"),
        Bullets((("Uncertain inputs: ", V((*ds, "uncertain_text")), "; each ln k normal around its value with "
                  "standard deviation ", V((*ds, "sigma_log_rate"), "g"), ", independent."),
                 ("Surrogate: ", V((*ds, "surrogate")), "; curvature grid ", V((*ds, "curvature_points"), "d"), " by ",
                  V((*ds, "curvature_points"), "d"), "."),
                 ("Map: ", V((*ds, "surrogate_samples"), "d"), " draws, the same at every grid point (seed ",
                  V((*ds, "seed"), "d"), ")."),
                 ("Verification: the full model by Monte Carlo on the first ", V((*ds, "verification", "samples"), "d"),
                  " draws at the points listed in the design-space section."),
                 ("Edges of failure: where the probability crosses the level, linear between grid points, along the "
                  "grid lines through the operating point.",))),
        Heading("Verification"),
        checks,
        Paragraph(("Solver settings and timings are in the appendix.",), "note")))


def approval_section(data: dict) -> Section:
    """The document's identity and the block its readers sign."""
    return Section("Document control and approval", (
        Table(("item", "value"), (("document ID", V(("document", "id"))), ("version", V(("document", "version"))),
                                  ("computed at", V(("provenance", "timestamp_utc")))),
              ("This document (the ID follows from the process file: the same file, the same ID)",)),
        Table(("role", "name", "signature", "date"),
              tuple((V(("document", "roles", k)), "", "", "") for k in range(len(data["document"]["roles"]))),
              ("Approval",))))


def appendix_section(data: dict) -> Section:
    """Solver settings and timings: for the modeller, not the reader who signs."""
    solver = tuple(row for key, value in data["solver_text"].items() for row in (
        [(f"{key}: {option}", V(("solver_text", key, option))) for option in value] if isinstance(value, dict)
        else [(key, V(("solver_text", key)))]))
    timings = Table(("step", "seconds"), (
        ("sensitivities, median of the timed calls", V(("timings", "seconds_median"), ",.2f", " s")),
        ("sensitivities, compile (first call less the median)", V(("timings", "compile_seconds"), ",.1f", " s")),
        ("sensitivity study with its checks", V(("timings", "study_seconds"), ",.1f", " s")),
        ("design space: surrogate map", V(("timings", "design_space_surrogate_seconds"), ",.1f", " s")),
        ("design space: full Monte Carlo", V(("timings", "design_space_monte_carlo_seconds"), ",.1f", " s")),
        ("criticality: the full model at the PAR's ends", V(("timings", "range_ends_seconds"), ",.1f", " s")),
        ("everything computed for this report", V(("timings", "total_seconds"), ",.1f", " s"))), ("Timings",))
    return Section("Appendix: solver settings and timings", (
        Table(("setting", "value"), solver, ("Solver settings of every unit",)), timings))


def sections(data: dict) -> tuple[Section, ...]:
    from ._report_fit import fit_section

    fit = fit_section(data)
    return (executive_summary(data), process_section(data), nominal_section(data), balance_section(data),
            sensitivity_section(data), design_space_section(data), *([fit] if fit else []), methods_section(data),
            approval_section(data), appendix_section(data))
