"""Built-in facility/curve pairs beyond the sample, for tests and the benchmark."""

import numpy as np

from ._inputs import sample_curve, sample_facility

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


CASES = {
    "sample": lambda: (sample_facility(), sample_curve()),
    "peaking_winter_spike": peaking_winter_spike,
    "depleted_field": depleted_field,
    "salt_cavern": salt_cavern,
}
