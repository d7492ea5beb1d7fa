"""Rolling intrinsic against an independent NumPy loop: on each re-optimisation day the intrinsic
dynamic program over the inventory levels on the day's conditional curve, then each day of the
block the trade that maximises today's cash at the spot plus tomorrow's intrinsic value.

The facility's rates, floors and start are whole multiples of the level spacing, so the exact
feasible moves from a level are the levels in reach (the production code's ends and holding
coincide with levels) and both sides choose among the same moves. The conditional curve is the
price model's (`conditional_curve`, tested against simulation with the models); what is tested
here is the rolling programme itself: the backward passes, the stale continuation between
re-optimisations, the terminal floor, costs and discounting."""

import jax
import numpy as np
import pytest

from finance.gas_storage._inputs import make_inputs
from finance.gas_storage._lsmc import inventory_grid
from finance.gas_storage._model import stochastic_scene
from finance.gas_storage._price_model_file import sample_price_model
from finance.gas_storage._price_models import model_paths
from finance.gas_storage._rolling_intrinsic import rolling_intrinsic

FLAT = [[0.0, 1.0], [1.0, 1.0]]
FACILITY = dict(capacity=1_000.0, initial_inventory=300.0, terminal_inventory_min=300.0, max_injection=200.0,
                max_withdrawal=300.0, injection_ratchet=FLAT, withdrawal_ratchet=FLAT, fuel_loss=0.0,
                injection_cost=0.01, withdrawal_cost=0.02, rate=0.05)
DAYS, PATHS, LEVELS = 12, 24, 11


def _reference(curve, spot, ratios, every):
    """Cash per path of rolling intrinsic re-optimised every `every` days; `ratios[p, t]` is
    E_t[S_u] / F_u (u = 0..T-1) on path p, day t."""
    f = FACILITY
    levels = np.linspace(0.0, f["capacity"], LEVELS)
    floor = np.zeros(DAYS + 1)
    floor[DAYS] = f["terminal_inventory_min"]
    for t in range(DAYS - 1, -1, -1):
        floor[t] = max(floor[t + 1] - f["max_injection"], 0.0)

    def cash(move, price, day):
        injected, withdrawn = np.maximum(move, 0), np.maximum(-move, 0)
        paid = -(price + f["injection_cost"]) * injected + (price - f["withdrawal_cost"]) * withdrawn
        return paid * np.exp(-f["rate"] / 365.0 * day)

    def allowed(start, day):  # (len(start), N): level n reachable from start on `day`
        move = levels[None, :] - start[:, None]
        return (move <= f["max_injection"] + 1e-9) & (move >= -f["max_withdrawal"] - 1e-9) & (
            levels[None, :] >= floor[day + 1] - 1e-9)

    totals = np.zeros(len(spot))
    for p in range(len(spot)):
        inventory = f["initial_inventory"]
        for t0 in range(0, DAYS, every):
            on = curve * ratios[p, t0]
            later = {DAYS: np.zeros(LEVELS)}  # V_u over the levels, on day t0's curve
            for u in range(DAYS - 1, t0, -1):
                score = cash(levels[None, :] - levels[:, None], on[u], u) + later[u + 1][None, :]
                later[u] = np.where(allowed(levels, u), score, -np.inf).max(axis=1)
            for t in range(t0, min(t0 + every, DAYS)):
                score = cash(levels - inventory, spot[p, t], t) + later[t + 1]
                chosen = levels[np.argmax(np.where(allowed(np.array([inventory]), t)[0], score, -np.inf))]
                totals[p] += cash(chosen - inventory, spot[p, t], t)
                inventory = chosen
    return totals


@pytest.mark.parametrize("every", [1, 5])
def test_rolling_intrinsic_equals_an_independent_loop(every):
    curve = 3.0 + 0.4 * np.sin(np.arange(DAYS) / 2.0) + 0.1 * np.random.default_rng(4).standard_normal(DAYS)
    inputs = make_inputs(FACILITY, curve)
    scene = stochastic_scene()
    model = sample_price_model("two-factor")
    paths = model_paths(model, inputs.forward_curve, PATHS, jax.random.key(5))
    got = np.asarray(rolling_intrinsic(model, inputs, scene, inventory_grid(inputs, scene, LEVELS), paths,
                                       every).value)
    spot = curve * np.exp(np.asarray(paths.log_ratio))
    ratios = np.stack([np.asarray(model.conditional_curve(paths.factors[:, t], t, DAYS)) for t in range(DAYS)], 1)
    expected = _reference(curve, spot, ratios, every)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9 * FACILITY["capacity"])
    # Not vacuous: the paths trade (the values differ from path to path).
    assert np.std(expected) > 1.0
