"""The solver family: one file per method, `base` (`AbstractSolver`, what a solver outside
Diffrax implements) and `settings` (`SolverSettings`, the one configuration every ODE solve in the
project goes through, and the registry of names the CLI and JSON edge choose solvers by).

- `rosenbrock`: Rodas4 and Rodas5, linearly implicit, Diffrax solvers.
- `bdf` (with `bdf_formulas`, `bdf_search`): `BDF`, a variable-order BDF for forward solves,
  replayed differentiably.
- `host`: peer solvers on the host (`CVODE`, `ScipyBDF`, `ScipyRadau`, `ScipyLSODA`).

Adding a solver: a file with its class (a Diffrax adaptive solver, or an `AbstractSolver`) and
one `register_solver(name, make, stiff=...)` call in `settings` (or in a plugin).
"""
