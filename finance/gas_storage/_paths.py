"""Price paths given as data rather than as normal shocks: a desk's own simulated paths, or those
of a multi-factor price model (`_price_models.py`).

A `PricePaths` goes wherever the one-factor model's `shocks` go (`spot_prices` reads it), so
every method (the policy's simulation and training, LSMC, the bound, the deltas) runs on it. The
paths are held as log(spot_t / F_t), not as the spot: the spot is rebuilt as F_t exp(log ratio),
so a forward-curve delta d value / d F_t moves every path's spot on day t in proportion, as the
one-factor model's pathwise deltas do (a parallel relative shift of that day's distribution).
"""

import equinox as eqx
import jax


class PricePaths(eqx.Module):
    """**Fields:** `log_ratio`: log(spot_t / F_t), shape (paths, T); `factors`: the price state
    the paths were simulated from (the policy and the LSMC basis may read it), shape
    (paths, T, k), or None when only the spot is known."""

    log_ratio: jax.Array
    factors: jax.Array | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """(paths, T), as the shocks it stands for."""
        return self.log_ratio.shape

    @property
    def dtype(self):
        return self.log_ratio.dtype

    def __getitem__(self, rows) -> "PricePaths":
        """The paths `rows` (a slice or an index array along the paths axis)."""
        return PricePaths(self.log_ratio[rows], None if self.factors is None else self.factors[rows])

    def state(self) -> jax.Array:
        """What the price state is known to be, shape (paths, T, k): the factors, or the log
        ratio alone (k = 1) when the file gave none."""
        return self.log_ratio[..., None] if self.factors is None else self.factors
