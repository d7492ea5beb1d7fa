"""A desk's own paths: files written from the built-in one-factor model and read back give the
built-in values and forward-curve deltas (to 1e-10); wrong files are refused in one line."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from finance import gas_storage as gs
from finance.gas_storage._lsmc_deltas import lsmc_value_and_deltas
from finance.gas_storage._path_files import load_paths, save_paths
from finance.gas_storage._paths import PricePaths
from finance.gas_storage._policy import expected_value, make_policy
from finance.gas_storage._model import spot_factor
from snapo_ode import InputError


def small_inputs(days=30):
    facility, curve = gs.CASES["bdj"]()
    facility = dict(facility, capacity=50_000.0, initial_inventory=20_000.0, terminal_inventory_min=20_000.0)
    return gs.make_inputs(facility, curve[120:120 + days], volatility=0.6018, mean_reversion=18.25)


def built_in_paths(inputs, shocks):
    return PricePaths(spot_factor(inputs, shocks))


@pytest.mark.parametrize("suffix", [".npz", ".parquet"])
def test_files_of_the_built_in_model_give_the_built_in_values_and_deltas(tmp_path, suffix):
    inputs = small_inputs()
    scene = gs.stochastic_scene()
    fit_shocks = jax.random.normal(jax.random.key(1), (300, inputs.n_days))
    eval_shocks = jax.random.normal(jax.random.key(2), (200, inputs.n_days))
    fit_file = save_paths(tmp_path / f"train{suffix}", inputs.forward_curve, built_in_paths(inputs, fit_shocks))
    eval_file = save_paths(tmp_path / f"value{suffix}", inputs.forward_curve, built_in_paths(inputs, eval_shocks))
    fit_paths, eval_paths = (load_paths(f, inputs.forward_curve) for f in (fit_file, eval_file))
    grid = gs.inventory_grid(inputs, scene, 21)
    # LSMC: regressions on the training file, value and one-pass deltas on the value file.
    built_fit = gs.fit_lsmc(inputs, scene, grid, gs.spot_prices(inputs, fit_shocks)[0], 3)
    file_fit = gs.fit_lsmc(inputs, scene, grid, gs.spot_prices(inputs, fit_paths)[0], 3)
    np.testing.assert_allclose(file_fit.coefficients, built_fit.coefficients, rtol=1e-10, atol=1e-6)
    built_value, built_deltas = lsmc_value_and_deltas(built_fit, inputs, scene, grid, eval_shocks)
    file_value, file_deltas = lsmc_value_and_deltas(file_fit, inputs, scene, grid, eval_paths)
    assert abs(float(file_value - built_value)) <= 1e-10 * abs(float(built_value))
    np.testing.assert_allclose(file_deltas, built_deltas, rtol=1e-10, atol=1e-10 * np.abs(built_deltas).max())
    # The policy: smooth value and its adjoint deltas on the value file.
    policy = make_policy(scene, inputs, key=jax.random.key(0), head="basestock", spot_scale=0.13)

    def value_and_deltas(shocks):
        def value(curve):
            return expected_value(policy, eqx_with_curve(inputs, curve), scene, sharpness=200.0, shocks=shocks)
        return jax.value_and_grad(value)(inputs.forward_curve)

    built_value, built_deltas = value_and_deltas(eval_shocks)
    file_value, file_deltas = value_and_deltas(eval_paths)
    assert abs(float(file_value - built_value)) <= 1e-10 * abs(float(built_value))
    np.testing.assert_allclose(file_deltas, built_deltas, rtol=1e-10, atol=1e-10 * np.abs(built_deltas).max())


def eqx_with_curve(inputs, curve):
    import equinox as eqx
    return eqx.tree_at(lambda i: i.forward_curve, inputs, curve)


def test_factors_round_trip_through_parquet(tmp_path):
    curve = np.linspace(3.0, 4.0, 12)
    rng = np.random.default_rng(0)
    paths = PricePaths(jnp.asarray(rng.normal(0, 0.1, (5, 12))), jnp.asarray(rng.normal(0, 1, (5, 12, 2))))
    back = load_paths(save_paths(tmp_path / "p.parquet", curve, paths), curve, factor_count=2)
    np.testing.assert_allclose(back.log_ratio, paths.log_ratio, atol=1e-14)
    np.testing.assert_array_equal(back.factors, paths.factors)


@pytest.mark.parametrize("arrays, message", [
    (dict(spot=np.full((4, 11), 3.0)), "11 days of spot; the forward curve has 12"),
    (dict(spot=np.full((4, 12, 1), 3.0)), "spot has shape (4, 12, 1)"),
    (dict(spot=np.where(np.eye(4, 12) > 0, np.nan, 3.0)), "spot[0, 0] = nan"),
    (dict(spot=np.full((4, 12), -1.0)), "spot[0, 0] = -1.0; allowed: a finite price > 0"),
    (dict(spot=np.full((4, 12), 3.0), factors=np.zeros((4, 12))), "factors has shape (4, 12)"),
    (dict(spot=np.full((4, 12), 3.0), factors=np.zeros((4, 12, 3))), "3 factors; the price model has 2"),
    (dict(price=np.full((4, 12), 3.0)), "an entry 'price.npy'"),
])
def test_bad_paths_files_are_refused_in_one_line(tmp_path, arrays, message):
    path = tmp_path / "paths.npz"
    np.savez(path, **arrays)
    with pytest.raises(InputError) as error:
        load_paths(path, np.full(12, 3.0), factor_count=2)
    assert message in str(error.value) and str(path) in str(error.value) and "\n" not in str(error.value)


def test_parquet_missing_a_day_is_refused(tmp_path):
    import pandas as pd
    path = tmp_path / "paths.parquet"
    pd.DataFrame({"path": [0, 0, 1], "day": [0, 1, 0], "spot": [3.0, 3.0, 3.0]}).to_parquet(path)
    with pytest.raises(InputError, match="every path needs every day"):
        load_paths(path, np.full(2, 3.0))
