"""The critical quality attributes of the dried product, hard spec checks for reporting and
smooth spec penalties for training."""

import jax
import jax.numpy as jnp
import numpy as np

from ..kinetics._types import Batch, Scalar, Vector
from ._chain import ChainResult
from ._ranges import CQA_NAMES, CQA_SPECS


def cqa_vector(result: ChainResult) -> Vector:
    """[assay % w/w, impurity % w/w, degradant % w/w, mean_crystal_size um, residual_solvent ppm],
    in the order of `CQA_NAMES`."""
    product = result.product
    total = product.total
    return jnp.stack([
        100 * product.api / total,
        100 * product.impurity / total,
        100 * product.degradant / total,
        1e6 * result.crystallizer.mean_size(),
        1e6 * product.solvent / total,
    ])


def _bounds():
    return np.array([s.low for s in CQA_SPECS]), np.array([s.high for s in CQA_SPECS])


def spec_margins(cqas) -> Batch:
    """Signed margin of each CQA to its nearest spec limit, relative to the limit's scale
    (positive inside the spec), shape like `cqas`."""
    low, high = _bounds()
    scale = np.where(np.isfinite(high), np.abs(high), np.abs(low))
    margin_low = jnp.where(np.isfinite(low), cqas - np.where(np.isfinite(low), low, 0.0), jnp.inf)
    margin_high = jnp.where(np.isfinite(high), np.where(np.isfinite(high), high, 0.0) - cqas, jnp.inf)
    return jnp.minimum(margin_low, margin_high) / scale


def meets_specs(cqas) -> Batch:
    """Hard check: 1.0 where every CQA is inside its spec, else 0.0 (shape `cqas.shape[:-1]`)."""
    return jnp.all(spec_margins(cqas) >= 0, axis=-1).astype(float)


def spec_penalty(cqas, sharpness: float = 50.0) -> Scalar:
    """Smooth penalty: sum over CQAs of softplus(-sharpness * margin) / sharpness, near zero
    inside the specs and growing linearly (in relative margin) outside."""
    return jnp.sum(jax.nn.softplus(-sharpness * spec_margins(cqas)) / sharpness)


def cqa_dict(cqas) -> dict[str, float]:
    return {name: float(value) for name, value in zip(CQA_NAMES, np.asarray(cqas), strict=True)}
