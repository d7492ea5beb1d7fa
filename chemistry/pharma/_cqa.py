"""The critical quality attributes of the dried product from the CQA vocabulary (a process file's
`cqas`), hard spec checks for reporting and smooth spec penalties for training.

The vocabulary, each computed in its unit (`_process_file.CQA_UNITS`) and converted to the
file's: `assay` (API in the product as it leaves the last unit, % w/w), `purity` (API in the
product's solids, dry basis, % w/w), `mass_fraction` of a tracked species (the API, the impurity
or the degradant, % w/w), `residual_solvent` (ppm w/w) and `loss_on_drying` (% w/w): the solvent
and antisolvent together, `{residual_solvent: species}` one of them alone (ppm w/w: ICH Q3C
limits are per solvent), `d43` (the volume-weighted mean crystal size, um), `yield` (API made and
isolated over the first fed species, mol %: the product's API less the seed crystals charged)
and `yield_including_seed` (the product's API, seeds included, over the same)."""

import jax
import jax.numpy as jnp
import numpy as np

from ..kinetics._types import Batch, Scalar, Vector
from ._chain import ChainResult
from ._process_file import ProcessSpec, load_process


def _specs(process: ProcessSpec | None):
    return (process or load_process()).cqas


def _value(result: ChainResult, definition, roles: dict):
    product = result.product
    if definition == "assay":
        return 100 * product.api / product.total
    if definition == "purity":
        return 100 * product.api / product.solids
    if definition == "loss_on_drying":
        return 100 * product.solvent / product.total
    if definition == "residual_solvent":
        return 1e6 * product.solvent / product.total
    if definition == "d43":
        return 1e6 * result.crystallizer.mean_size()
    if definition == "yield":
        return result.api_yield
    if definition == "yield_including_seed":
        return result.api_yield_including_seed
    kind, species = definition
    if kind == "residual_solvent":  # the solvent is first in `by_solvent`, the antisolvent second
        if product.by_solvent is None:
            raise ValueError(f"CQA {{residual_solvent: {species}}}: the process's last unit does not split the "
                             "solvent by species (Solids.by_solvent); state residual_solvent instead.")
        return 1e6 * product.by_solvent[0 if roles[species] == "solvent" else 1] / product.total
    return 100 * getattr(product, roles[species]) / product.total  # ("mass_fraction", species)


def cqa_vector(result: ChainResult, process: ProcessSpec | None = None) -> Vector:
    """The CQAs of `process` (default: the built-in) in its order, each in its file's unit; the
    built-in: [assay % w/w, impurity % w/w, degradant % w/w, mean_crystal_size um,
    residual_solvent ppm]."""
    process = process or load_process()
    values = []
    for spec in process.cqas:
        value = _value(result, spec.definition, process.roles)
        values.append(value if spec.factor == 1.0 else spec.factor * value)
    return jnp.stack(values)


def _bounds(process):
    specs = _specs(process)
    return np.array([s.low for s in specs]), np.array([s.high for s in specs])


def spec_margins(cqas, process: ProcessSpec | None = None) -> Batch:
    """Signed margin of each CQA to its nearest spec limit, relative to the limit's scale
    (positive inside the spec), shape like `cqas`."""
    low, high = _bounds(process)
    scale = np.where(np.isfinite(high), np.abs(high), np.abs(low))
    margin_low = jnp.where(np.isfinite(low), cqas - np.where(np.isfinite(low), low, 0.0), jnp.inf)
    margin_high = jnp.where(np.isfinite(high), np.where(np.isfinite(high), high, 0.0) - cqas, jnp.inf)
    return jnp.minimum(margin_low, margin_high) / scale


def meets_specs(cqas, process: ProcessSpec | None = None) -> Batch:
    """Hard check: 1.0 where every CQA is inside its spec, else 0.0 (shape `cqas.shape[:-1]`)."""
    return jnp.all(spec_margins(cqas, process) >= 0, axis=-1).astype(float)


def spec_penalty(cqas, sharpness: float = 50.0, process: ProcessSpec | None = None) -> Scalar:
    """Smooth penalty: sum over CQAs of softplus(-sharpness * margin) / sharpness, near zero
    inside the specs and growing linearly (in relative margin) outside."""
    return jnp.sum(jax.nn.softplus(-sharpness * spec_margins(cqas, process)) / sharpness)


def cqa_dict(cqas, process: ProcessSpec | None = None) -> dict[str, float]:
    names = [spec.name for spec in _specs(process)]
    return {name: float(value) for name, value in zip(names, np.asarray(cqas), strict=True)}
