"""The solver family: one file per method, and `base` (`SolverSettings`, the one configuration
every ODE solve in the project goes through, with the names the CLI and JSON edge choose by).

- `rosenbrock`: Rodas4 and Rodas5, linearly implicit, for Diffrax.
- `bdf` (with `bdf_formulas`, `bdf_search`): a variable-order BDF for forward solves, replayed
  differentiably.
- `host`: peer solvers on the host (SUNDIALS CVODE, SciPy).
"""
