"""The storage facility, the forward curve and the market model, as one differentiable pytree.

Every field is a float array so that one reverse pass gives the sensitivity of the value to
each of them. Validation runs in NumPy, before anything is traced.
"""

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from snapo_ode import InputError, check_finite, check_increasing, check_range, check_scalar, require_float64

DAYS_PER_YEAR = 365.0
FACILITY_FIELDS = (
    "capacity",
    "initial_inventory",
    "terminal_inventory_min",
    "max_injection",
    "max_withdrawal",
    "injection_ratchet",
    "withdrawal_ratchet",
    "fuel_loss",
    "injection_cost",
    "withdrawal_cost",
    "rate",
)


# Magnitudes beyond which the model's arithmetic (value ~ capacity x price, smoothed flows of
# order rate / capacity) loses its precision: far beyond any real facility or market.
MAX_QUANTITY = 1e12  # capacity, inventories [MMBtu] and daily rates [MMBtu/day], at most
MAX_PRICE = 1e6  # |price| and costs [$/MMBtu], at most


class StorageInputs(eqx.Module):
    """Inputs of the gas-storage model (units: energy in MMBtu, or any unit used consistently
    with the curve; money per that unit; days).

    **Fields:**
    - `forward_curve`: F_t [$/MMBtu], shape (T,).
    - `capacity`, `initial_inventory`, `terminal_inventory_min` [MMBtu].
    - `max_injection`, `max_withdrawal` [MMBtu/day], before ratchets.
    - `injection_ratchet`, `withdrawal_ratchet`: shape (m, 2), rows `[fill_fraction,
      rate_fraction]` with fill fractions increasing from 0 to 1.
    - `fuel_loss` [fraction of injected gas lost], `injection_cost`, `withdrawal_cost` [$/MMBtu].
    - `rate`: continuously compounded discount rate [1/year]; DF_t = exp(-rate t / 365).
    - `volatility` [1/sqrt(year)] and `mean_reversion` [1/year] of the Ornstein-Uhlenbeck factor
      X of the stochastic spot, spot_t = F_t exp(X_t - Var(X_t)/2).
    """

    forward_curve: jax.Array
    capacity: jax.Array
    initial_inventory: jax.Array
    terminal_inventory_min: jax.Array
    max_injection: jax.Array
    max_withdrawal: jax.Array
    injection_ratchet: jax.Array
    withdrawal_ratchet: jax.Array
    fuel_loss: jax.Array
    injection_cost: jax.Array
    withdrawal_cost: jax.Array
    rate: jax.Array
    volatility: jax.Array
    mean_reversion: jax.Array

    @property
    def n_days(self) -> int:
        return self.forward_curve.shape[0]


def _check_ratchet(field: str, table) -> np.ndarray:
    array = check_finite(field, table)
    if array.ndim != 2 or array.shape[1] != 2 or array.shape[0] < 2:
        raise InputError(
            f"{field} must be a table [[fill_fraction, rate_fraction], ...] with at least two rows; "
            f"got shape {array.shape}."
        )
    check_increasing(f"{field} fill fractions", array[:, 0])
    if array[0, 0] != 0.0 or array[-1, 0] != 1.0:
        raise InputError(
            f"{field} fill fractions must run from 0 to 1; got {array[0, 0]:g} to {array[-1, 0]:g}."
        )
    check_range(f"{field} rate fractions", array[:, 1], 0.0, 1.0)
    return array


def make_inputs(facility: dict, forward_curve, *, volatility: float = 0.0,
                mean_reversion: float = 0.0) -> StorageInputs:
    """Validate a facility dict (the JSON fields) and a forward curve, and build `StorageInputs`.

    Prices may be negative (they occur in gas and power markets); the stochastic spot, which is
    log-normal, needs positive ones (`check_positive_prices`).

    **Raises:** `InputError` naming the field, its value and the allowed range, for: a missing or
    unknown field, non-finite prices, a curve that is zero on every day, capacity <= 0, a
    quantity above MAX_QUANTITY or a price or cost above MAX_PRICE in magnitude, an initial inventory outside
    [0, capacity], a malformed or non-increasing ratchet table, or a terminal requirement that
    cannot be reached at the maximum injection rate.
    """
    require_float64("gas storage inputs")
    missing = [name for name in FACILITY_FIELDS if name not in facility]
    unknown = sorted(set(facility) - set(FACILITY_FIELDS))
    if missing or unknown:
        raise InputError(
            f"facility fields missing: {missing or 'none'}; unknown: {unknown or 'none'}. "
            f"Expected exactly: {', '.join(FACILITY_FIELDS)}."
        )
    curve = check_range("forward_curve (price)", forward_curve, -MAX_PRICE, MAX_PRICE)
    if curve.ndim != 1 or curve.size < 2:
        raise InputError(f"forward_curve must hold at least two daily prices; got shape {curve.shape}.")
    if not np.any(curve):
        raise InputError("forward_curve is zero on every day: nothing to value, and no price scale to train on.")
    capacity = check_scalar("capacity", facility["capacity"], 0.0, MAX_QUANTITY, low_open=True)
    initial = check_scalar("initial_inventory", facility["initial_inventory"], 0.0, capacity)
    terminal = check_scalar("terminal_inventory_min", facility["terminal_inventory_min"], 0.0, capacity)
    max_injection = check_scalar("max_injection", facility["max_injection"], 0.0, MAX_QUANTITY)
    max_withdrawal = check_scalar("max_withdrawal", facility["max_withdrawal"], 0.0, MAX_QUANTITY)
    fuel_loss = check_scalar("fuel_loss", facility["fuel_loss"], 0.0, 1.0, high_open=True)
    injection_ratchet = _check_ratchet("injection_ratchet", facility["injection_ratchet"])
    withdrawal_ratchet = _check_ratchet("withdrawal_ratchet", facility["withdrawal_ratchet"])
    injection_cost = check_scalar("injection_cost", facility["injection_cost"], 0.0, MAX_PRICE)
    withdrawal_cost = check_scalar("withdrawal_cost", facility["withdrawal_cost"], 0.0, MAX_PRICE)
    rate = check_scalar("rate", facility["rate"], -1.0, 1.0)
    check_scalar("volatility", volatility, 0.0, 10.0)
    check_scalar("mean_reversion", mean_reversion, 0.0, 1e4)
    # In Python floats: a huge (finite) max_injection overflows to inf, which compares right,
    # without NumPy's overflow warning.
    reachable = initial + (1 - fuel_loss) * max_injection * float(injection_ratchet[:, 1].max()) * curve.size
    if terminal > min(reachable, capacity) + 1e-9 * capacity:
        raise InputError(
            f"terminal_inventory_min = {terminal:g} cannot be reached: at most {min(reachable, capacity):g} "
            f"can be in store after {curve.size} days at the maximum injection rate from "
            f"initial_inventory = {initial:g}."
        )
    as_array = lambda x: jnp.asarray(x, dtype=jnp.float64)  # noqa: E731
    return StorageInputs(
        forward_curve=as_array(curve),
        capacity=as_array(capacity),
        initial_inventory=as_array(initial),
        terminal_inventory_min=as_array(terminal),
        max_injection=as_array(max_injection),
        max_withdrawal=as_array(max_withdrawal),
        injection_ratchet=as_array(injection_ratchet),
        withdrawal_ratchet=as_array(withdrawal_ratchet),
        fuel_loss=as_array(fuel_loss),
        injection_cost=as_array(injection_cost),
        withdrawal_cost=as_array(withdrawal_cost),
        rate=as_array(rate),
        volatility=as_array(volatility),
        mean_reversion=as_array(mean_reversion),
    )


def check_positive_prices(inputs: StorageInputs) -> None:
    """Raise `InputError` unless every forward price is positive: the stochastic spot is
    log-normal around the curve (spot_t = F_t exp(X_t - Var/2)), so a zero or negative F_t has no
    such spot."""
    curve = np.asarray(inputs.forward_curve)
    if np.any(curve <= 0):
        day = int(np.argmax(curve <= 0))
        raise InputError(f"forward_curve[{day}] = {curve[day]:g}: the stochastic spot is log-normal around the "
                         "forward curve (spot = F exp(X)), so every price must be positive; value a curve with "
                         "zero or negative prices in the deterministic (intrinsic) model.")
