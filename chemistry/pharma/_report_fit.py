"""The report's section "How the uncertainty was obtained", where the design space draws from a
fit's posterior file: the data against the model per experiment, the parameter table with its
intervals, the correlation matrix, and the design space under the fitted uncertainty beside the
one under independent ln k of one sigma."""

from snapo_ode import Paragraph, Section, Table, Value

V = Value
KEY = "uncertainty_fit"
COMPARED = ("operating_probability", "nor_min_probability", "par_min_probability", "fraction_meeting_level")


def fit_data(posterior, independent: dict, fitted_space: dict) -> dict:
    """The section's data: the posterior's fit summary (`posterior.fit`, written by `snapo pharma
    fit`), its covariance's names, and the design space's key figures under the posterior
    (`fitted_space`, JSON) and under independent sigma (`independent`, JSON)."""
    fit = dict(posterior.fit or {})
    return {"process": posterior.process, "parameters": fit.get("parameters", {}),
            "correlation": fit.get("correlation", {"names": [], "matrix": []}),
            "experiments": fit.get("experiments", {}), "residuals": fit.get("residuals", []),
            "goodness_of_fit": fit.get("goodness_of_fit", {}),
            "comparison": {"posterior": {k: fitted_space[k] for k in COMPARED},
                           "independent": {k: independent[k] for k in COMPARED},
                           "sigma_log_rate": independent["sigma_log_rate"],
                           "acceptable_ranges": {"posterior": fitted_space["acceptable_ranges"],
                                                 "independent": independent["acceptable_ranges"]}}}


def _interval(path: tuple, value):
    """A 95% interval's cell: low – high as values, or "not determined" (no bound from the data)."""
    if value is None or None in value:
        return "not determined"
    return (V((*path, 0), ".5g"), "\u00a0\u2013\u00a0", V((*path, 1), ".5g"))


def fit_section(data: dict) -> Section | None:
    """The section, or None where the report was not given a posterior."""
    fit = data.get(KEY)
    if fit is None:
        return None
    base = (KEY,)
    parameters = tuple((name, V((*base, "parameters", name, "estimate"), ".6g"), p["unit"],
                        V((*base, "parameters", name, "standard_error"), ".3g") if p["standard_error"] is not None
                        else "-", _interval((*base, "parameters", name, "wald_95"), p["wald_95"]),
                        _interval((*base, "parameters", name, "profile_95"), p["profile_95"]))
                       for name, p in fit["parameters"].items())
    names = fit["correlation"]["names"]
    correlation = tuple((name, *(V((*base, "correlation", "matrix", i, j), "+.3f") for j in range(len(names))))
                        for i, name in enumerate(names))
    residuals = tuple((r["experiment"], V((*base, "residuals", k, "time_min"), "g"), r["species"], V((*base, "residuals", k, "measured"), ".5g"),
                       V((*base, "residuals", k, "model"), ".5g"), V((*base, "residuals", k, "weighted_residual"), "+.2f"))
                      for k, r in enumerate(fit["residuals"]))
    compare = tuple((key.replace("_", " "), V((*base, "comparison", "posterior", key), ".4f"),
                     V((*base, "comparison", "independent", key), ".4f")) for key in COMPARED)
    goodness = (("(", V((*base, "goodness_of_fit", "chi_square"), ".4g"), " chi-square on ",
                 V((*base, "goodness_of_fit", "dof"), "d"), " degrees of freedom)")
                if fit["goodness_of_fit"] else ("(the posterior file carries no summary of the fit)",))
    return Section("How the uncertainty was obtained", (
        Paragraph(("The rate parameters' uncertainty is the posterior of a weighted least-squares fit of the "
                   "process's kinetics to lab experiments ", *goodness, ". The design space draws the parameters "
                   "from it, correlated, at the fitted values.")),
        Table(("parameter", "estimate", "unit", "standard error", "95% (Wald)", "95% (profile likelihood)"),
              parameters, ("The fitted parameters",), csv="fit_parameters.csv"),
        Table(("", *names), correlation, ("Their correlation matrix",)),
        Table(("figure", "under the fitted posterior", "under independent ln k of sigma"), compare,
              ("The design space under the fitted uncertainty beside the one under independent ln k of sigma ",
               V((*base, "comparison", "sigma_log_rate"), "g"),)),
        Table(("experiment", "time [min]", "species", "measured [mol/L]", "model [mol/L]", "weighted residual"),
              residuals, ("The data against the model, per experiment",), csv="fit_residuals.csv"),
    ))
