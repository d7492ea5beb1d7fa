"""Built-in facility/curve pairs beyond the sample, for tests and the benchmark."""

import numpy as np

from ._files import sample_curve, sample_facility

FLAT_RATCHET = [[0.0, 1.0], [1.0, 1.0]]
_DAYS = np.arange(365)


def peaking_winter_spike() -> tuple[dict, np.ndarray]:
    """A 500,000 MMBtu peaking facility on a curve with a two-week cold-snap spike in winter."""
    curve = (3.0 + 0.3 * np.cos(2 * np.pi * (_DAYS - 280) / 365)
             + 1.2 * np.exp(-0.5 * ((_DAYS - 300) / 12.0) ** 2))
    facility = dict(capacity=500_000.0, initial_inventory=100_000.0, terminal_inventory_min=100_000.0,
                    max_injection=8_000.0, max_withdrawal=15_000.0,
                    injection_ratchet=[[0.0, 1.0], [0.5, 1.0], [1.0, 0.5]],
                    withdrawal_ratchet=[[0.0, 0.4], [0.25, 1.0], [1.0, 1.0]],
                    fuel_loss=0.01, injection_cost=0.015, withdrawal_cost=0.01, rate=0.03)
    return facility, curve


def depleted_field() -> tuple[dict, np.ndarray]:
    """A slow 2 million MMBtu field in contango, drawn down to 40% by the end, with strong ratchets."""
    curve = 2.6 + 0.9 * _DAYS / 365 + 0.3 * np.cos(2 * np.pi * (_DAYS - 300) / 365)
    facility = dict(capacity=2_000_000.0, initial_inventory=1_000_000.0, terminal_inventory_min=800_000.0,
                    max_injection=15_000.0, max_withdrawal=25_000.0,
                    injection_ratchet=[[0.0, 1.0], [0.6, 0.9], [1.0, 0.4]],
                    withdrawal_ratchet=[[0.0, 0.3], [0.5, 1.0], [1.0, 1.0]],
                    fuel_loss=0.02, injection_cost=0.03, withdrawal_cost=0.02, rate=0.05)
    return facility, curve


def salt_cavern() -> tuple[dict, np.ndarray]:
    """A fast-cycling 300,000 MMBtu cavern (fills in 10 days) on a curve with quarterly swings on
    top of the season: the hardest case for the policy (see the benchmark)."""
    curve = 3.0 + 0.2 * np.sin(2 * np.pi * _DAYS / 91.0) + 0.4 * np.cos(2 * np.pi * (_DAYS - 290) / 365)
    facility = dict(capacity=300_000.0, initial_inventory=0.0, terminal_inventory_min=0.0,
                    max_injection=30_000.0, max_withdrawal=60_000.0, injection_ratchet=FLAT_RATCHET,
                    withdrawal_ratchet=FLAT_RATCHET, fuel_loss=0.005, injection_cost=0.01,
                    withdrawal_cost=0.01, rate=0.04)
    return facility, curve


# Boogert & de Jong (2008), "Gas storage valuation using a Monte Carlo method", J. Derivatives
# 15(3), Exhibit 1: one-factor Schwartz spot, mean reversion 0.05/day, volatility 3.15% or 9.45%
# per sqrt(day), converted to the model's units (365 days a year, exact daily OU steps).
BDJ_MEAN_REVERSION = 0.05 * 365.0  # [1/year]
BDJ_VOLATILITY = {"low": 0.0315 * np.sqrt(365.0), "high": 0.0945 * np.sqrt(365.0)}  # [1/sqrt(year)]
BDJ_PUBLISHED = {"intrinsic": 2.7e6, "lsmc_low": 3.1e6, "lsmc_high": 5.4e6}  # [EUR]
BDJ_JULY, BDJ_FEBRUARY = slice(0, 31), slice(215, 243)  # days from 1 Jul 2005
BDJ_PEAK_DAY = 198  # 15 Jan 2006


def boogert_de_jong() -> tuple[dict, np.ndarray]:
    """The B&dJ (2008) contract: 365 days from 1 Jul 2005 [EUR/MWh, MWh], capacity 250,000, start
    and end 100,000, injection 2,500/day, withdrawal 7,500/day, no costs, no discounting. The
    forward curve is stylised: a + b cos(2 pi (t - 198) / 365), peaking on 15 Jan 2006, with a, b
    fitted so that the July 2005 mean is 14.88 and the February 2006 mean 25.44 (the two
    published TTF quotes)."""
    season = np.cos(2 * np.pi * (_DAYS - BDJ_PEAK_DAY) / 365.0)
    level, amplitude = np.linalg.solve([[1.0, season[BDJ_JULY].mean()], [1.0, season[BDJ_FEBRUARY].mean()]],
                                       [14.88, 25.44])
    facility = dict(capacity=250_000.0, initial_inventory=100_000.0, terminal_inventory_min=100_000.0,
                    max_injection=2_500.0, max_withdrawal=7_500.0, injection_ratchet=FLAT_RATCHET,
                    withdrawal_ratchet=FLAT_RATCHET, fuel_loss=0.0, injection_cost=0.0, withdrawal_cost=0.0,
                    rate=0.0)
    return facility, level + amplitude * season


CASES = {
    "sample": lambda: (sample_facility(), sample_curve()),
    "peaking_winter_spike": peaking_winter_spike,
    "depleted_field": depleted_field,
    "salt_cavern": salt_cavern,
    "bdj": boogert_de_jong,
}
