"""Kinetics fitted to lab data: the lab files' one-line errors, the fit's residual Jacobian against
central differences, its estimates against SciPy's least_squares on the same model and data, an
unidentifiable pair named, and the design space under the fitted covariance against full Monte
Carlo."""

import json

import numpy as np
import pytest
import scipy.optimize

from chemistry.pharma import BUMP_SOLVER, PharmaChain, design_space, make_cpps
from chemistry.pharma._experiments import ErrorModel, Experiment, read_lab_data
from chemistry.pharma._fit import fit, residual_functions
from chemistry.pharma._fit_model import experiment_model, fitted_parameters
from chemistry.pharma._fit_synthetic import data_csv, experiments_yaml, lab_design, simulate_lab_data
from chemistry.pharma._posterior import Posterior, posterior_from_fit, read_posterior, write_posterior
from snapo_ode import InputError

FIT = ["log_multiplier[A + B => P]", "E_a[A + B => P]", "log_multiplier[P => I]"]


@pytest.fixture(scope="module")
def chain():
    return PharmaChain()


@pytest.fixture(scope="module")
def lab(chain):
    """Two runs at 30 and 50 degC, A, P and I at five times, simulated off the mechanism's kinetics
    (ln k of the synthesis +0.2, its activation shifted, the over-reaction -0.3) with noise."""
    experiments = (Experiment("cold", "r1", 303.15, {"A": 0.33, "B": 0.363}),
                   Experiment("hot", "r1", 323.15, {"A": 0.30, "B": 0.40}))
    errors = {"A": ErrorModel(0.002, 0.01), "P": ErrorModel(0.002, 0.01), "I": ErrorModel(1e-4, 0.02)}
    data = lab_design(experiments, [5, 15, 30, 60, 120], ["A", "P", "I"], errors)
    fitted = fitted_parameters(chain, data, FIT)
    truth = np.array([0.2, -0.3, 0.15])
    return simulate_lab_data(chain, data, fitted, truth, seed=1), fitted, truth


def _write(tmp_path, experiments: str, csv: str):
    (tmp_path / "e.yaml").write_text(experiments)
    (tmp_path / "d.csv").write_text(csv)
    return tmp_path / "e.yaml", tmp_path / "d.csv"


EXPERIMENTS = """experiments:
  - name: run1
    unit: r1
    temperature: 40 degC
    charges: {A: 0.33 mol/L, B: 363 mmol/L}
"""


@pytest.mark.parametrize("csv, message", [
    ("experiment,time [min],species,value [mol/L]\nrun2,5,P,0.1\n", r"d.csv, line 2: experiment = 'run2'"),
    ("experiment,time [min],species,value [mol/L]\nrun1,5,Q,0.1\n", r"line 2: species = 'Q'"),
    ("experiment,time [min],species,value [mol/L]\nrun1,10,P,0.1\nrun1,5,P,0.2\n", r"line 3: time = 5 is not after"),
    ("experiment,time [min],species,value [mol/L]\nrun1,-1,P,0.1\n", r"line 2: time = -1; allowed: >= 0"),
    ("experiment,time [kg],species,value [mol/L]\nrun1,1,P,0.1\n", r"line 1: time: 'kg' does not convert"),
    ("experiment,time [min],species,value [mol/L]\nrun1,1,P,1_0\n", r"line 2: value = '1_0' is not a decimal"),
    ("experiment,time,species,value [mol/L]\nrun1,1,P,0.1\n", r"line 1: column 'time' states no unit"),
])
def test_data_file_errors_name_the_line(chain, tmp_path, csv, message):
    paths = _write(tmp_path, EXPERIMENTS, csv)
    with pytest.raises(InputError, match=message):
        read_lab_data(*paths, chain.process, chain.mechanism.species_names)


@pytest.mark.parametrize("text, message", [
    (EXPERIMENTS.replace("unit: r1", "unit: dryer"), r"e.yaml, line 3: experiments\[run1\].unit = 'dryer'"),
    (EXPERIMENTS.replace("{A: 0.33", "{Z: 0.33"), r"line 5: experiments\[run1\].charges names 'Z'"),
    (EXPERIMENTS.replace("40 degC", "40 kg"), r"line 4: experiments\[run1\].temperature = '40 kg' does not convert"),
])
def test_experiments_file_errors_name_the_line(chain, tmp_path, text, message):
    paths = _write(tmp_path, text, "experiment,time [min],species,value [mol/L]\nrun1,5,P,0.1\n")
    with pytest.raises(InputError, match=message):
        read_lab_data(*paths, chain.process, chain.mechanism.species_names)


def test_units_convert_and_an_unknown_parameter_is_refused(chain, tmp_path):
    paths = _write(tmp_path, EXPERIMENTS, "experiment,time [h],species,value [mmol/L],sd [mmol/L]\nrun1,0.5,P,100,2\n")
    data = read_lab_data(*paths, chain.process, chain.mechanism.species_names)
    assert data.measurements.time[0] == 30.0 and data.measurements.value[0] == pytest.approx(0.1, rel=1e-12)
    assert data.measurements.sd[0] == pytest.approx(0.002, rel=1e-12)
    assert data.experiments[0].temperature == pytest.approx(313.15) and data.experiments[0].charges["B"] == pytest.approx(0.363, rel=1e-12)
    with pytest.raises(InputError, match=r"--fit 'log_multiplier\[A => Q\]': no such parameter"):
        fitted_parameters(chain, data, ["log_multiplier[A => Q]"])


def test_written_example_files_read_back(chain, lab, tmp_path):
    data, _, _ = lab
    paths = _write(tmp_path, experiments_yaml(data, "test"), data_csv(data))
    again = read_lab_data(*paths, chain.process, chain.mechanism.species_names)
    np.testing.assert_allclose(again.measurements.value, data.measurements.value, rtol=1e-7)
    np.testing.assert_allclose(again.sd(), data.sd(), rtol=1e-6)


def test_residual_jacobian_equals_central_differences(lab):
    # At the bump tolerances (rtol 1e-10): the differences' solver noise (~1e-10 of a concentration over an sd of
    # ~1e-3, divided by 2 steps) is ~1e-5 of a column's largest entry; the comparison allows 1e-4 of it.
    data, fitted, truth = lab
    chain = PharmaChain(solver=BUMP_SOLVER)
    residuals, with_jacobian = residual_functions(experiment_model(chain, data, fitted), data.measurements.value,
                                                  data.sd())
    r, jacobian = with_jacobian(truth)
    # The residuals come with the Jacobian from its one forward-mode pass: the forward simulation's own values.
    reference = np.asarray(residuals(truth))
    np.testing.assert_allclose(np.asarray(r), reference, rtol=1e-12, atol=1e-12 * np.abs(reference).max())
    step = 1e-3  # BUMP_RELATIVE_STEP: truncation ~1e-7, solver noise ~1e-10 / 1e-3
    for k in range(len(truth)):
        bump = np.zeros(len(truth))
        bump[k] = step
        central = (np.asarray(residuals(truth + bump)) - np.asarray(residuals(truth - bump))) / (2 * step)
        np.testing.assert_allclose(np.asarray(jacobian)[:, k], central, rtol=1e-5,
                                   atol=1e-4 * np.abs(central).max())


def test_estimates_equal_scipy_least_squares(chain, lab):
    data, fitted, truth = lab
    result = fit(chain, data, FIT, profile=False)
    residuals, with_jacobian = residual_functions(experiment_model(chain, data, fitted), data.measurements.value,
                                                  data.sd())
    reference = scipy.optimize.least_squares(lambda t: np.asarray(residuals(t)), np.zeros(len(truth)),
                                             jac=lambda t: np.asarray(with_jacobian(t)[1]), method="lm",
                                             xtol=1e-15, ftol=1e-15, gtol=1e-15)
    se = np.sqrt(np.diag(result.theta_covariance))
    # The same optimum to a millionth of a standard error: the parameters are correlated (a multiplier and
    # its activation energy), so along that valley the two solvers stop ~1e-7 apart, varying with the CPU.
    assert np.all(np.abs(result.theta - reference.x) <= 1e-6 * se + 1e-12), (result.theta - reference.x, se)
    assert result.sd_known and result.dof == len(data.measurements.value) - 3
    # The truth lies within 4 standard errors (one noisy dataset), and the Wald interval is estimate +/- 1.96 se.
    assert np.all(np.abs(result.theta - truth) <= 4 * se)
    np.testing.assert_allclose(result.wald()[:, 1] - result.estimates, 1.959964 * result.standard_errors, rtol=1e-6)
    assert not result.null_combinations


def test_an_unidentifiable_pair_is_named(chain, lab):
    data, _, _ = lab
    # A <=> X equilibrates in milliseconds: samples at minutes fix K = k(A=>X) / k(X=>A), never their sum.
    result = fit(chain, data, ["log_multiplier[A + B => P]", "log_multiplier[A => X]", "log_multiplier[X => A]"],
                 profile=False)
    (combination,) = result.null_combinations
    coefficients = combination["coefficients"]
    assert set(coefficients) == {"log_multiplier[A => X]", "log_multiplier[X => A]"}
    assert np.allclose(list(coefficients.values()), [2 ** -0.5] * 2, atol=0.05)
    assert np.isnan(result.wald()[1:]).all() and np.isfinite(result.wald()[0]).all()


def test_posterior_file_round_trip_and_errors(chain, lab, tmp_path):
    data, _, _ = lab
    result = fit(chain, data, FIT, profile=False)
    posterior = posterior_from_fit(result, chain, "api_chain")
    assert posterior.names == ("log_multiplier[A + B => P]", "log_multiplier[P => I]",
                               "activation_temperature[A + B => P]")
    write_posterior(posterior, tmp_path / "p.json")
    again = read_posterior(tmp_path / "p.json", chain)
    np.testing.assert_array_equal(again.covariance, posterior.covariance)
    # The draws' covariance is the posterior's.
    draws = posterior.draws(np.random.default_rng(0).standard_normal((200_000, 3)))
    np.testing.assert_allclose(np.cov(draws.T), posterior.covariance, rtol=0.02, atol=1e-3 * posterior.covariance.max())
    (tmp_path / "bad.json").write_text((tmp_path / "p.json").read_text().replace("P => I", "P => Q"))
    with pytest.raises(InputError, match=r"bad.json: names has 'log_multiplier\[P => Q\]'"):
        read_posterior(tmp_path / "bad.json", chain)


def test_design_space_under_the_posterior_agrees_with_full_monte_carlo():
    # A posterior with a strong correlation between the synthesis's ln k and activation temperature.
    chain = PharmaChain(solver=BUMP_SOLVER)
    base = chain.rate_parameters
    j, i = chain.mechanism.reaction_equations.index("A + B => P"), chain.mechanism.reaction_equations.index("P => I")
    covariance = np.array([[0.04, 0.0, 0.03], [0.0, 0.02, 0.0], [0.03, 0.0, 0.04]])
    posterior = Posterior(("log_multiplier[A + B => P]", "log_multiplier[P => I]", "activation_temperature[A + B => P]"),
                          np.array([0.1, 0.2, float(base.activation_temperature[j]) + 50.0]),
                          np.array([1.0, 1.0, 313.0]), covariance, "api_chain")
    space = design_space(chain, make_cpps(), points=3, verify_points=4, samples=47, surrogate_samples=512,
                         curvature_points=2, posterior=posterior)
    assert space.uncertainty["source"] == "posterior" and space.uncertain == list(posterior.names)
    check = space.verification
    assert check["all_within_se"] and check["max_difference_over_se"] <= 1.0
    assert i != j


def test_fit_verb_writes_the_json_and_the_posterior(chain, lab, tmp_path, capsys):
    from snapo_ode.cli import main

    data, _, _ = lab
    paths = _write(tmp_path, experiments_yaml(data, "test"), data_csv(data))
    lab_args = ["--experiments", str(paths[0]), "--data", str(paths[1]), *(f"--fit={name}" for name in FIT)]
    (tmp_path / "bad.csv").write_text("experiment,time [min],species,value [mol/L]\ncold,5,Q,0.1\n")
    assert main(["pharma", "fit", "--experiments", str(paths[0]), "--data", str(tmp_path / "bad.csv"),
                 "--json", str(tmp_path / "bad.json")]) == 2
    assert "bad.csv, line 2: species = 'Q'" in capsys.readouterr().err
    assert main(["pharma", "fit", *lab_args, "--no-profile", "--json", str(tmp_path / "fit.json")]) == 0
    written = json.loads((tmp_path / "fit.json").read_text())
    np.testing.assert_allclose(np.diag(written["correlation"]["matrix"]), 1.0, rtol=1e-12)
    assert written["identifiability"]["rank"] == 3 and written["goodness_of_fit"]["dof"] == 27
    assert list(written["parameters"]) == ["ln_k_ref[A + B => P]", "log_multiplier[P => I]", "E_a[A + B => P]"]
    posterior = read_posterior(tmp_path / "fit.posterior.json", chain)
    assert posterior.fit["parameters"] == written["parameters"]
    reference = fit(chain, read_lab_data(*paths, chain.process, chain.mechanism.species_names), FIT, profile=False)
    np.testing.assert_allclose([p["estimate"] for p in written["parameters"].values()], reference.estimates,
                               rtol=1e-9)
    # The report's section: every value it shows is a path into the data, and each resolves.
    from chemistry.pharma._report_fit import fit_data, fit_section
    from snapo_ode import Paragraph, Table, Value

    space = {"operating_probability": 0.97, "nor_min_probability": 0.9, "par_min_probability": 0.2,
             "fraction_meeting_level": 0.5, "sigma_log_rate": 0.1, "acceptable_ranges": {}}
    report_data = {"uncertainty_fit": fit_data(posterior, independent=space, fitted_space=space)}
    section = fit_section(report_data)
    assert section.title == "How the uncertainty was obtained" and fit_section({}) is None

    def values(item):
        if isinstance(item, Value):
            yield item
        elif isinstance(item, (tuple, list)):
            for part in item:
                yield from values(part)
        elif isinstance(item, Table):
            yield from values(item.rows)
        elif isinstance(item, Paragraph):
            yield from values(item.parts)

    shown = list(values(section.blocks))
    assert len(shown) > 3 * len(data.measurements.value)
    for value in shown:
        entry = report_data
        for key in value.path:
            entry = entry[key]
        assert entry is not None, value.path


def _ranked_by_edge(chain, lab):
    """A fit of the lab data, the edge map over r1_temperature x dryer_temperature under its posterior, and three
    candidates ranked by the edge: hot, cold, and one with no A charged (nothing reacts, so its measurements depend
    on no parameter: a Jacobian of zeros)."""
    from chemistry.pharma._edge_uncertainty import edge_map
    from chemistry.pharma._next_experiment import rank_candidates

    data, _, _ = lab
    result = fit(chain, data, FIT, profile=False)
    edge = edge_map(chain, chain.inputs(make_cpps()), posterior_from_fit(result, chain, "api_chain"),
                    x="r1_temperature", y="dryer_temperature", points=3)
    candidates = (Experiment("hot", "r1", 333.15, {"A": 0.33, "B": 0.363}),
                  Experiment("cold", "r1", 298.15, {"A": 0.33, "B": 0.363}),
                  Experiment("nothing", "r1", 313.15, {"A": 0.0, "B": 0.363}))
    return candidates, rank_candidates(chain, data, result, candidates, [30, 90], ["A", "P", "I"], edge=edge,
                                       rank_by="edge")


@pytest.fixture(scope="module")
def ranked(chain, lab):
    return _ranked_by_edge(chain, lab)


def _verb(tmp_path, lab, candidates) -> list[str]:
    data, _, _ = lab
    paths = _write(tmp_path, experiments_yaml(data, "test"), data_csv(data))
    (tmp_path / "c.yaml").write_text(experiments_yaml(data._replace(experiments=candidates), "candidates"))
    return ["pharma", "next-experiment", "--experiments", str(paths[0]), "--data", str(paths[1]),
            *(f"--fit={name}" for name in FIT), "--candidates", str(tmp_path / "c.yaml"), "--species", "A,P,I",
            "--times", "30,90", "--points", "3", "--json", str(tmp_path / "next.json")]


@pytest.mark.slow
def test_candidates_ranked_by_the_design_space_edge(ranked):
    # Slow for its fit and the candidates' Jacobian compiles (30-50 s here); the edge's arithmetic, the gain's sign and
    # its zero without information are tested fast in test_pharma_edge.py.
    candidates, by_edge = ranked
    assert by_edge[0]["edge_uncertainty_now"] > 0
    gains = [row["edge_gain"] for row in by_edge]
    assert gains == sorted(gains, reverse=True) and min(gains) >= 0 and gains[0] > 0
    nothing = next(row for row in by_edge if row["name"] == "nothing")
    assert nothing["edge_gain"] == 0.0 and abs(nothing["log_det_gain"]) < 1e-9


def test_next_experiment_refuses_a_bad_ranking_or_grid_in_one_line(lab, tmp_path, capsys):
    from snapo_ode.cli import main

    verb = _verb(tmp_path, lab, (Experiment("hot", "r1", 333.15, {"A": 0.33, "B": 0.363}),))
    for flags, message in ((["--rank-by", "volume"], "--rank-by = 'volume' is not one of: 'd-optimal', 'edge'."),
                           (["--x", "r2_temperature"], "x = 'r2_temperature' is not one of: "),
                           (["--points", "2"], "points = 2; allowed: a whole number in [3, 201].")):
        assert main([*verb, *flags]) == 2
        error = capsys.readouterr().err.strip()
        assert error.startswith(f"snapo: error: {message}") and "\n" not in error


@pytest.mark.slow
def test_next_experiment_verb_reports_the_edge_for_every_candidate(ranked, lab, tmp_path):
    # By default D-optimal as before; the edge's fields on every candidate all the same.
    from snapo_ode.cli import main

    candidates, by_edge = ranked
    assert main(_verb(tmp_path, lab, candidates)) == 0
    written = json.loads((tmp_path / "next.json").read_text())
    assert written["rank_by"] == "d-optimal" and written["criterion"] == "D-optimal: ln det(F + J_c^T J_c) - ln det F"
    information = [row["log_det_gain"] for row in written["ranking"]]
    assert information == sorted(information, reverse=True)
    expected = {row["name"]: row for row in by_edge}
    for row in written["ranking"]:
        assert row["log_det_gain"] == pytest.approx(expected[row["name"]]["log_det_gain"], rel=1e-5, abs=1e-9)
        assert row["edge_gain"] == pytest.approx(expected[row["name"]]["edge_gain"], rel=1e-5, abs=1e-15)
        assert row["edge_gain"] == pytest.approx(row["edge_uncertainty_now"] - row["edge_uncertainty_after"], abs=1e-15)
    assert written["edge"]["x"] == "r1_temperature" and written["edge"]["points"] == 3
    assert written["edge"]["uncertainty_now"] == pytest.approx(by_edge[0]["edge_uncertainty_now"], rel=1e-5)
