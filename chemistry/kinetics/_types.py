"""The array types of the chemistry package (jaxtyping), named once so that annotations read
`temperature: Scalar` and linters see no shape strings. Shapes and units are in each docstring."""

from jaxtyping import Array, Bool, Float, Int

Scalar = Float[Array, ""]
"""A float scalar."""
Vector = Float[Array, " n"]
"""A 1-D float array (per species, per reaction, ...)."""
Matrix = Float[Array, "m n"]
"""A 2-D float array."""
Batch = Float[Array, "..."]
"""A float array of any shape."""
Indices = Int[Array, " n"]
"""A 1-D integer array of indices."""
IndexMatrix = Int[Array, "m n"]
"""A 2-D integer array of indices (padded rows)."""
Mask = Bool[Array, " n"]
"""A 1-D boolean array."""
