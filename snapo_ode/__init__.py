"""snapo-ode: Smooth Neural Adjoint Policy Optimization on differentiable simulators.

Importing the package changes no global JAX state: call `snapo_ode.configure()` once (the `snapo`
CLI, the tests and the notebooks do) to turn on float64 and the persistent compilation cache.
Entry points that need float64 (sensitivities, stiff solves) raise `ConfigurationError` without it.
Public names load lazily, on first use (`snapo_ode._platform.lazy`).
"""

from importlib.metadata import PackageNotFoundError, version

from ._platform.lazy import lazy_exports

try:
    __version__ = version("snapo-ode")
except PackageNotFoundError:  # run from a source tree that was never installed
    __version__ = "0+unknown"

__getattr__, __dir__, __all__ = lazy_exports(__name__, {
    "._runtime.accuracy": ("AccuracyStudy", "Panel", "Point", "cheapest", "read_accuracy", "timed_point", "write_accuracy"),
    "._platform.config": ("ConfigurationError", "configure", "default_cache_dir", "require_float64"),
    "._platform.cache_trust": ("CacheUnavailable",),
    "._platform.devices": ("SAMPLES", "check_divisible", "generate_sharded", "initialize", "is_writer", "mesh_of",
                      "per_sample", "sample_mean", "sample_mesh", "spec", "start", "to_host", "use_cpu_devices"),
    "._effects": ("EffectCatalogue", "Scene"),
    "._platform.files": ("MANIFEST", "atomic_write_bytes", "atomic_write_json", "atomic_write_text", "check_replaceable_directory",
             "json_bytes", "publish", "publish_directory", "sha256"),
    "._runtime.export_keys": ("Unkeyable", "describe"),
    "._runtime.exported": ("ONCE_COMPILE", "QUICK_COMPILE", "ExportedProgram", "exported"),
    "._jaxpr": ("count_operations",),
    "._platform.lazy": ("lazy_exports",),
    "._ode": ("SolveResult", "SolverFailed", "call_checked", "diffeqsolve_checked", "prefetch_checked", "raise_if_failed"),
    "._runtime.pdf": ("PdfUnavailable", "count_pages", "find_chromium", "print_pdf"),
    "._periodic": ("Periodic", "cosine_square", "wrap", "wrapped_square"),
    "._policy": ("MLPPolicy", "load_policy", "policy_bytes", "save_policy"),
    "._runtime.provenance": ("git_state", "input_digest", "provenance"),
    "._runtime.report": ("WrittenReport", "csv_bytes", "write_report"),
    "._runtime.report_model": ("Bullets", "Figure", "Heading", "Highlights", "Paragraph", "Report", "Section", "Table",
                       "Value", "format_value", "lookup"),
    "._runtime.report_html": ("render_html",),
    "._platform.resources": ("available_memory", "check_memory", "memory_mappings", "relieve_mappings"),
    "._runtime.results": ("Result", "field", "jsonable"),
    "._rollout": ("DiscreteStepper", "RolloutMethod", "rollout"),
    "._solver.rosenbrock": ("Rodas4", "Rodas5"),
    "._sensitivity": ("Jacobian", "JacobianMode", "choose_mode", "flatten_inputs", "input_names", "jacobian",
                      "value_and_sensitivities"),
    "._solver.settings": ("SOLVERS", "STIFF_SOLVERS", "Solver", "SolverName", "SolverSettings", "register_solver",
                          "solver_from_name", "solver_name", "solver_names", "unregister_solver"),
    "._solver.base": ("AbstractSolver",),
    "._solver.bdf": ("BDF",),
    "._solver.host": ("CVODE", "ScipyBDF", "ScipyLSODA", "ScipyRadau"),
    "._runtime.tables": ("Column", "format_table", "records_csv", "write_table"),
    "._timing": ("Timing", "compiled_temp_bytes", "time_function", "time_once"),
    "._training": ("TrainingDiverged", "TrainResult", "default_optimizer", "train"),
    "._checkpoint": ("CheckpointInfo", "load_checkpoint", "save_checkpoint"),
    "._fingerprint": ("digest_of", "package_versions", "run_fingerprint"),
    "._platform.settings": ("Settings",),
    "._platform.reading": ("DECIMAL", "MAX_YAML_BYTES", "check_cantera_yaml", "check_npz", "check_parquet", "number_text", "read_yaml",
                           "whole_text"),
    "._platform.schema": ("STRICT_SCHEMA", "FiniteNumber", "IsoDate", "line_of", "read_text", "strict_json", "strict_yaml",
                          "validate"),
    "._platform.validation": ("InputError", "check_choice", "check_count", "check_finite", "check_increasing",
                     "check_range", "check_scalar"),
    "._verification": ("DEFAULT_RELATIVE_STEP", "Agreement", "BumpComparison", "agreement", "bump_and_revalue",
                       "bump_steps", "bumps_program", "central_differences", "compare_with_bumps", "max_relative_difference"),
}, submodules=("smooth", "cli"))
