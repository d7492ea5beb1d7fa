"""A family of storage contracts to tune and check on: generated forward curves and facilities of
the kinds a storage desk values, so that no method is tuned on one sample.

Curves (`curve(shape, days, seed)`), in $/MMBtu around a level of 3 (any unit used consistently):
- `seasonal`: a winter premium (peak in the middle of the first winter of the horizon);
- `weekly`: seasonal with a weekend discount (Saturday and Sunday ~6% below the weekdays);
- `holidays`: seasonal with a handful of single-day discounts of 8-15% (bank holidays);
- `spikes`: seasonal with single-day spikes of +15-40% (cold snaps, outages);
- `flat`: constant with a faint noise of 0.5%;
- `contango`: rising ~30% over the horizon, a small season on top;
- `backwardation`: falling ~25% over the horizon.
Facilities (`facility(kind, seed)`), all rates in MMBtu/day:
- `fast`: a salt cavern that fills in ~10 days and empties in ~5 (no ratchets, low costs);
- `slow`: a depleted field that fills in ~100 days and empties in ~40 (B&dJ's proportions);
- `ratchets`: the slow field with injection slowing as it fills and withdrawal as it empties;
- `fuel_costs`: 0.5-1% fuel loss and per-unit costs, a 4% rate;
- `everything`: ratchets, fuel loss, costs and discounting, with an off-grid initial inventory.
Numbers are drawn from a seeded generator, so a family is reproducible and a new seed gives
cases nobody tuned on. `family()` pairs shapes and kinds with horizons of 90, 180 and 365 days.
"""

from typing import NamedTuple

import numpy as np

CURVE_SHAPES = ("seasonal", "weekly", "holidays", "spikes", "flat", "contango", "backwardation")
FACILITY_KINDS = ("fast", "slow", "ratchets", "fuel_costs", "everything")

# (shape, kind, days): every shape and kind at least twice, short and long horizons.
FAMILY = (
    ("weekly", "slow", 365), ("holidays", "fast", 180), ("spikes", "ratchets", 90), ("seasonal", "fuel_costs", 365),
    ("flat", "fast", 90), ("contango", "slow", 180), ("backwardation", "ratchets", 180), ("weekly", "fuel_costs", 90),
    ("spikes", "everything", 365), ("holidays", "everything", 90), ("contango", "fuel_costs", 365),
    ("seasonal", "everything", 180), ("backwardation", "fast", 90), ("flat", "everything", 180),
)


class FamilyCase(NamedTuple):
    """One generated contract: `name` (shape-kind-days), the facility dict, the curve (T,)."""

    name: str
    facility: dict
    curve: np.ndarray


def curve(shape: str, days: int, seed: int = 0) -> np.ndarray:
    """A daily forward curve of `shape` (see the module docstring) over `days` days [$/MMBtu]."""
    if shape not in CURVE_SHAPES:
        raise ValueError(f"curve shape {shape!r}: use one of {', '.join(CURVE_SHAPES)}")
    rng = np.random.default_rng(seed)
    day = np.arange(days)
    level = 3.0 * rng.uniform(0.8, 1.2)
    season = level * (1 + rng.uniform(0.1, 0.25) * np.cos(2 * np.pi * (day - rng.uniform(150, 220)) / 365.0))
    if shape == "seasonal":
        return season
    if shape == "weekly":
        return season * (1 - rng.uniform(0.04, 0.08) * (day % 7 >= 5))
    if shape == "holidays":
        drops = np.zeros(days)
        drops[rng.choice(days, size=max(2, days // 40), replace=False)] = rng.uniform(0.08, 0.15, max(2, days // 40))
        return season * (1 - drops)
    if shape == "spikes":
        spikes = np.zeros(days)
        spikes[rng.choice(days, size=max(2, days // 45), replace=False)] = rng.uniform(0.15, 0.4, max(2, days // 45))
        return season * (1 + spikes)
    if shape == "flat":
        return level * (1 + 0.005 * rng.standard_normal(days))
    trend = rng.uniform(0.25, 0.35) if shape == "contango" else -rng.uniform(0.2, 0.3)
    return level * (1 + trend * day / days) * (1 + 0.05 * np.cos(2 * np.pi * day / 365.0))


def facility(kind: str, seed: int = 0) -> dict:
    """A facility of `kind` (see the module docstring), the JSON fields of `make_inputs`."""
    if kind not in FACILITY_KINDS:
        raise ValueError(f"facility kind {kind!r}: use one of {', '.join(FACILITY_KINDS)}")
    rng = np.random.default_rng(seed + 1_000)
    capacity = float(np.round(rng.uniform(2e5, 2e6), -3))
    flat = [[0.0, 1.0], [1.0, 1.0]]
    fill_days, empty_days = (rng.uniform(8, 12), rng.uniform(4, 6)) if kind == "fast" else (
        rng.uniform(80, 120), rng.uniform(30, 50))
    start = float(np.round(capacity * rng.uniform(0.1, 0.4), -3))
    fields = dict(capacity=capacity, initial_inventory=start, terminal_inventory_min=start,
                  max_injection=float(np.round(capacity / fill_days, -1)),
                  max_withdrawal=float(np.round(capacity / empty_days, -1)),
                  injection_ratchet=flat, withdrawal_ratchet=flat, fuel_loss=0.0, injection_cost=0.0,
                  withdrawal_cost=0.0, rate=0.0)
    if kind in ("ratchets", "everything"):
        fields.update(injection_ratchet=[[0.0, 1.0], [rng.uniform(0.5, 0.7), 1.0], [1.0, rng.uniform(0.4, 0.6)]],
                      withdrawal_ratchet=[[0.0, rng.uniform(0.3, 0.5)], [rng.uniform(0.2, 0.4), 1.0], [1.0, 1.0]])
    if kind in ("fuel_costs", "everything"):
        fields.update(fuel_loss=float(rng.uniform(0.005, 0.01)), injection_cost=float(rng.uniform(0.005, 0.02)),
                      withdrawal_cost=float(rng.uniform(0.005, 0.02)), rate=0.04)
    if kind == "everything":
        fields.update(initial_inventory=start + 1_234.5)
    return fields


def family(cases: int | None = None, seed: int = 0) -> list[FamilyCase]:
    """The first `cases` (default all) of `FAMILY`, generated with `seed` (each case its own
    stream)."""
    chosen = FAMILY if cases is None else FAMILY[:cases]
    return [FamilyCase(f"{shape}-{kind}-{days}", facility(kind, seed + 97 * index),
                       curve(shape, days, seed + 97 * index))
            for index, (shape, kind, days) in enumerate(chosen)]
