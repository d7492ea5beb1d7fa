"""Reading a design-space map: the acceptable range and the edges of failure along a grid line
through the operating point, where to verify the map by full Monte Carlo, and the standard
error of a Monte Carlo probability."""

from typing import NamedTuple

import numpy as np

from ._ranges import ParameterRange

BAND = (0.02, 0.998)  # where the probability is neither ~0 nor ~1
NEAR_LEVEL = 0.25  # verification points come first from where |P - level| <= this: the edge of failure


class AcceptableRange(NamedTuple):
    """Along one CPP (the other at its grid line through the operating point): `interval`
    [low, high] around the operating point where P >= level (None when the operating point
    itself falls short); `edge_low` / `edge_high`: where P crosses the level (linear between
    grid points; None when P stays >= level to the end of the PAR); the CPP's `nor` and `par`."""

    interval: list | None
    edge_low: float | None
    edge_high: float | None
    nor: tuple
    par: tuple

    def as_dict(self) -> dict:
        """The edges, the margins from the NOR to them [CPP units] (None: no edge inside the PAR,
        so the margin is at least `par - nor`), and that least margin."""
        return {"interval": self.interval, "edge_low": self.edge_low, "edge_high": self.edge_high,
                "margin_below_nor": None if self.edge_low is None else self.nor[0] - self.edge_low,
                "margin_above_nor": None if self.edge_high is None else self.edge_high - self.nor[1],
                "par_beyond_nor_low": self.nor[0] - self.par[0], "par_beyond_nor_high": self.par[1] - self.nor[1],
                "nor": list(self.nor), "par": list(self.par)}


def _crossing(v0: float, p0: float, v1: float, p1: float, level: float) -> float:
    """Where the line from (v0, p0 >= level) to (v1, p1 < level) crosses `level`."""
    return float(v0 + (p0 - level) / (p0 - p1) * (v1 - v0))


def acceptable_range(values: np.ndarray, probability: np.ndarray, index: int, level: float,
                     spec: ParameterRange) -> AcceptableRange:
    """The `AcceptableRange` along `values` (the grid over the PAR) with `probability` on it,
    from the operating point's grid index `index`."""
    nor, par = tuple(spec.nor), tuple(spec.par)
    if probability[index] < level:
        return AcceptableRange(None, None, None, nor, par)
    high = index
    while high + 1 < len(values) and probability[high + 1] >= level:
        high += 1
    low = index
    while low - 1 >= 0 and probability[low - 1] >= level:
        low -= 1
    edge_high = None if high == len(values) - 1 else _crossing(values[high], probability[high], values[high + 1],
                                                               probability[high + 1], level)
    edge_low = None if low == 0 else _crossing(values[low], probability[low], values[low - 1],
                                               probability[low - 1], level)
    interval = [float(values[0]) if edge_low is None else edge_low, float(values[-1]) if edge_high is None else edge_high]
    return AcceptableRange(interval, edge_low, edge_high, nor, par)


def choose_verification_points(probability: np.ndarray, operating: tuple[int, int], count: int,
                               level: float) -> list[tuple[int, int]]:
    """`count` grid points: the operating point's, then the point whose probability is nearest
    `level`, then points spread by farthest-point sampling (normalised grid coordinates), first
    from the edge of failure (within NEAR_LEVEL of the level, inside BAND), then from the rest of
    BAND, then from the other grid points."""
    n_x, n_y = probability.shape
    coords = np.stack(np.meshgrid(np.arange(n_x) / (n_x - 1), np.arange(n_y) / (n_y - 1), indexing="ij"), -1)
    chosen = [tuple(operating)]
    flat = probability.ravel()
    in_band = (flat >= BAND[0]) & (flat <= BAND[1])
    near = in_band & (np.abs(flat - level) <= NEAR_LEVEL)
    for first, pool in enumerate((near, in_band & ~near, ~in_band)):
        candidates = [divmod(int(k), n_y) for k in np.flatnonzero(pool) if divmod(int(k), n_y) not in chosen]
        if candidates and len(chosen) == 1 and first == 0:
            chosen.append(min(candidates, key=lambda ij: abs(probability[ij] - level)))
            candidates.remove(chosen[-1])
        while candidates and len(chosen) < count:
            distance = [min(np.linalg.norm(coords[c] - coords[o]) for o in chosen) for c in candidates]
            chosen.append(candidates.pop(int(np.argmax(distance))))
    return chosen[:count]


def probability_se(passes: int, n: int) -> float:
    """The standard error of a Monte Carlo probability: sqrt(q (1 - q) / n) with the add-one
    estimate q = (passes + 1) / (n + 2), so that it is not zero at 0 or n passes."""
    q = (passes + 1) / (n + 2)
    return float(np.sqrt(q * (1 - q) / n))
