"""Bad input gets an `InputError` naming the field, the value and the allowed range, raised
while building the study: before anything is traced or compiled."""

import numpy as np
import pytest

from finance import alm
from finance.alm._cli import register_alm
from snapo_ode import InputError
from snapo_ode.cli import main


@pytest.fixture(scope="module")
def defaults():
    study = alm.build_study(40, horizon_months=6)
    return {k: np.asarray(v) for k, v in {**study.fixed, **study.reported}.items()}


def _correlation():
    return alm.default_correlation(1)


def test_non_symmetric_correlation():
    corr = _correlation()
    corr[0, 3] = 0.5
    with pytest.raises(InputError, match=r"correlation is not symmetric: correlation\[0, 3\] = 0.5"):
        alm.build_study(40, correlation=corr)


def test_non_psd_correlation():
    corr = _correlation()
    corr[0, 1] = corr[1, 0] = 0.99
    corr[0, 2] = corr[2, 0] = 0.99
    corr[1, 2] = corr[2, 1] = -0.99
    with pytest.raises(InputError, match=r"not positive semidefinite: its smallest eigenvalue is "
                                         r"-\S+; allowed: >= 0"):
        alm.build_study(40, correlation=corr)


def test_correlation_of_the_wrong_shape_or_diagonal():
    with pytest.raises(InputError, match=r"correlation has shape \(3, 3\); expected \(6, 6\)"):
        alm.build_study(40, correlation=np.eye(3))
    corr = _correlation()
    corr[2, 2] = 2.0
    with pytest.raises(InputError, match=r"correlation\[2, 2\] = 2"):
        alm.build_study(40, correlation=corr)


@pytest.mark.parametrize("horizon", [0, -12, 601])
def test_horizon_outside_its_range(horizon):
    with pytest.raises(InputError, match=rf"horizon_months = {horizon}; allowed: an integer in \[1, 600\]"):
        alm.build_study(40, horizon_months=horizon)


def test_weight_bounds_that_cannot_sum_to_one():
    with pytest.raises(InputError, match=r"weight bounds cannot sum to 1: sum\(weight_low\) = 0 and "
                                         r"sum\(weight_high\) = 0.6"):
        alm.Market(alm.key_tenors(5), 1, weight_high=(0.1,) * 6)
    with pytest.raises(InputError, match=r"sum\(weight_low\) = 1.2"):
        alm.Market(alm.key_tenors(5), 1, weight_low=(0.2,) * 6, weight_high=(0.5,) * 6)


@pytest.mark.parametrize("group", ["rate_vols", "equity_vols", "inflation_vol", "spread_vol"])
def test_negative_volatility(defaults, group):
    factors = dict(defaults)
    factors[group] = -np.abs(factors[group]) - 0.01
    with pytest.raises(InputError, match=rf"{group}(\[0\])? = -\S+ is outside the allowed range \[0, 2\]"):
        alm.build_study(40, factors=factors)


@pytest.mark.parametrize("group", ["key_rates", "liability_cash_flows", "holdings", "spread"])
def test_nan_anywhere(defaults, group):
    factors = dict(defaults)
    value = np.array(factors[group], dtype=float)
    value.flat[-1] = np.nan
    factors[group] = value
    with pytest.raises(InputError, match=rf"{group}(\[\d+\])? = nan is not a finite number"):
        alm.build_study(40, factors=factors)


def test_too_few_risk_factors_and_bad_counts():
    with pytest.raises(InputError, match=r"risk_factors = 5; allowed: an integer >= 9"):
        alm.build_study(5)
    study = alm.build_study(40, horizon_months=6)
    with pytest.raises(InputError, match=r"paths = 0; allowed: a whole number >= 1"):
        alm.scenarios(study, 0, None)


def test_cli_reports_bad_input_without_compiling(tmp_path, monkeypatch, capsys):
    import jax

    def no_compile(*args, **kwargs):
        raise AssertionError("nothing may be compiled before the inputs are checked")

    monkeypatch.setattr(jax, "jit", no_compile)
    assert main(["alm", "--horizon-months", "0", "--json", str(tmp_path / "o.json")], plugins=[register_alm]) == 2
    assert "--horizon-months: 0 is out of range: allowed >= 1" in capsys.readouterr().err
    assert not (tmp_path / "o.json").exists()
