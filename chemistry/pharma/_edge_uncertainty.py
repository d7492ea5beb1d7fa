"""The design space's edge uncertainty under a covariance of the fitted kinetics, and its expected
reduction by an experiment.

Each spec limit l (a CQA against its low or its high limit) is met where its log margin
g_l(x) = +-(ln CQA - ln limit) is >= 0; at the fitted kinetics its edge is the curve g_l = 0 in
the plane of the design space's two CPPs. With the posterior's coordinates normal, covariance C,
and ln CQA linear in them (the design space's first-order surrogate, S = d ln CQA / d coordinate
from the adjoint), g_l(x) is normal with standard deviation s(x) = sqrt(G C G^T), G = +-S, and
the edge moves normal to itself by s / |grad_x g|: its **location standard deviation**. The
**edge uncertainty** is that standard deviation integrated along the edges, summed over the
limits,

    U(C) = sum_l integral over {g_l = 0} of s_l / |grad_x g_l| dl,

in the CPPs scaled to their PARs (the PAR box is the unit square, so U is a fraction of it: the
edges' length times their mean location standard deviation). It is the thin-band limit of the
integrated Bernoulli variance with which the excursion-set literature measures how well a region's
boundary is known (Bect et al., Statistics and Computing 22, 2012): the area integral of p (1 - p),
p = Phi(g / s) the probability of meeting the limit, tends to U / sqrt(pi); unlike it, U needs no
grid finer than the band where p moves from 0 to 1, which under a fitted posterior is far
narrower than a grid cell.

After an experiment the covariance is C' (its Fisher information added) and the mean moves by what
its data will show, before they are taken distributed N(0, C - C'). The expected p' (1 - p') at a
point is then Phi(h) - Phi2(h, h; 1 - s'^2 / s^2), h = g / s, whose integral across the edge is
s' / (sqrt(pi) |grad_x g|): in the same limit the expected edge uncertainty after the experiment
is U(C'), exactly, and the expected reduction U(C) - U(C') is never negative (s' <= s at every
point, as C' <= C) and zero for an experiment that carries no information.

The edges are traced on the design space's grid: each cell is cut into two triangles, on each of
which g is linear (its value at the corners), so an edge crosses it as a straight segment; s is
linear along the triangle's sides, and the segment contributes its length times the mean of s at
its ends over |grad_x g| there.
"""

from typing import NamedTuple

import numpy as np

from ._chain import PharmaChain
from ._parameters import ChainInputs


class EdgeMap(NamedTuple):
    """The spec limits over the design space's grid of `x` and `y` (`xs`, `ys`, over their PARs):
    `limits` (n_limits, "CQA >= low" or "CQA <= high"), their log `margins` (n_x, n_y, n_limits;
    positive where met, at the posterior's mean) and the margins' `sensitivities` to the
    posterior's coordinates (n_x, n_y, n_limits, m)."""

    x: str
    y: str
    xs: np.ndarray
    ys: np.ndarray
    limits: tuple[str, ...]
    margins: np.ndarray
    sensitivities: np.ndarray

    def spread(self, covariance: np.ndarray) -> np.ndarray:
        """The standard deviation s of each log margin (n_x, n_y, n_limits) under `covariance` (m, m)."""
        g = self.sensitivities
        return np.sqrt(np.clip(np.einsum("...i,ij,...j->...", g, covariance, g), 0.0, None))

    def uncertainty_by_limit(self, covariance: np.ndarray) -> np.ndarray:
        """U of each limit (n_limits,) under `covariance` [fraction of the PAR box]."""
        return _edge_integral(self.margins, self.spread(covariance))

    def uncertainty(self, covariance: np.ndarray) -> float:
        """The edge uncertainty U under `covariance` (m, m) [fraction of the PAR box]; under the covariance
        after an experiment, the edge uncertainty expected after it."""
        return float(np.sum(self.uncertainty_by_limit(covariance)))

    def edge_length(self) -> np.ndarray:
        """The length of each limit's edge inside the PAR box (n_limits,) [PAR box sides]."""
        return _edge_integral(self.margins, np.ones_like(self.margins), per_gradient=False)


_TRIANGLES = (((0, 0), (1, 0), (1, 1)), ((0, 0), (1, 1), (0, 1)))
"""A grid cell's two triangles, as (i, j) offsets of their corners from the cell's lower-left one."""


def _edge_integral(g: np.ndarray, s: np.ndarray, per_gradient: bool = True) -> np.ndarray:
    """The integral of s / |grad g| (or of 1, with `per_gradient` False) along {g = 0}, g and s
    (n_x, n_y, n_limits) on a grid over the unit square, g linear on each cell's two triangles;
    per limit (n_limits,)."""
    n_x, n_y, _ = g.shape
    step = np.array([1.0 / (n_x - 1), 1.0 / (n_y - 1)])
    total = np.zeros(g.shape[-1])
    for corners in _TRIANGLES:
        offsets = np.array(corners, float) * step
        gs = [g[i:n_x - 1 + i, j:n_y - 1 + j] for i, j in corners]
        ss = [s[i:n_x - 1 + i, j:n_y - 1 + j] for i, j in corners]
        # grad g from g = g0 + a . (p - p0) at the other two corners (unit-square coordinates)
        edges = offsets[1:] - offsets[0]
        gradient = np.einsum("ij,...j->...i", np.linalg.inv(edges), np.stack([gs[1] - gs[0], gs[2] - gs[0]], -1))
        norm = np.linalg.norm(gradient, axis=-1)
        ends, spreads = [], []
        for a, b in ((0, 1), (1, 2), (2, 0)):  # a sign (g >= 0) changes on two sides of a triangle or on none
            crossing = (gs[a] >= 0) != (gs[b] >= 0)
            t = np.where(crossing, gs[a] / np.where(crossing, gs[a] - gs[b], 1.0), np.nan)
            ends.append(offsets[a] + t[..., None] * (offsets[b] - offsets[a]))
            spreads.append(ss[a] + t * (ss[b] - ss[a]))
        length = sum(np.nan_to_num(np.linalg.norm(ends[a] - ends[b], axis=-1)) for a, b in ((0, 1), (1, 2), (2, 0)))
        weight = 0.5 * np.nansum(spreads, axis=0) / np.where(norm > 0, norm, 1.0) if per_gradient else 1.0
        total += np.sum(length * weight, axis=(0, 1))
    return total


def edge_map(chain: PharmaChain, inputs: ChainInputs, posterior, *, x: str, y: str, points: int,
             mesh=None) -> EdgeMap:
    """The `EdgeMap` of the CPPs `x` and `y` on a `points` x `points` grid over their PARs at
    `inputs` (the other CPPs), the rate inputs at the mean of `posterior` (`_posterior.Posterior`):
    the CQAs and their sensitivities to its coordinates from one reverse-mode Jacobian per grid
    point, as the design space takes them (`grid_sensitivities`)."""
    from ._design_space import grid_sensitivities
    from ._posterior import posterior_inputs
    from ._sensitivities import jacobians_function

    ranges = {r.name: r for r in chain.cpp_ranges}
    xs, ys = np.linspace(*ranges[x].par, points), np.linspace(*ranges[y].par, points)
    inputs = posterior_inputs(chain, inputs, posterior)
    values, slopes = grid_sensitivities(jacobians_function(chain, True, "reverse", mesh), chain, inputs, (x, xs),
                                        (y, ys), list(posterior.names), posterior.scales)
    limits, margins, sensitivities = [], [], []
    for c, spec in enumerate(chain.process.cqas):
        for limit, sign, text in ((spec.low, 1.0, ">="), (spec.high, -1.0, "<=")):
            if limit is None or not np.isfinite(limit) or limit <= 0:  # a CQA is positive: met
                continue
            limits.append(f"{spec.name} {text} {limit:g}")
            margins.append(sign * (np.log(values[..., c]) - np.log(limit)))
            sensitivities.append(sign * slopes[..., c, :])
    return EdgeMap(x, y, xs, ys, tuple(limits), np.stack(margins, -1), np.stack(sensitivities, -2))
