"""`snapo gas --price-model FILE.yaml`: every method on the desk's price model (`_model_study.py`),
on paths it simulates or on the desk's own paths files: one JSON, the trained policy beside it
(`OUT.policy.eqx`, as the one-factor `snapo gas` saves its own; `load_storage_policy` reads it)."""

import sys

import jax

from snapo_ode import InputError, check_count, json_bytes, publish, sha256


def run_gas_on_model(args, inputs, settings) -> int:
    """`args`' price model and paths files on the contract `inputs`, with the study's `settings`
    (paths, seed, progress); everything is read and checked before any compile."""
    from ._model_study import STATE_DEGREE, value_on_model
    from ._path_files import paths_of_args
    from ._price_model_file import load_price_model
    from ._price_models import model_paths
    from ._state_policy import state_policy_bytes

    degree = STATE_DEGREE if args.lsmc_degree is None else args.lsmc_degree
    check_count("--lsmc-degree", degree, 1, 6)  # the state's monomials (`state_basis`)
    model = load_price_model(args.price_model)
    training, evaluation = paths_of_args(args, inputs, factor_count=len(model.factor_names))
    for file, given in ((args.train_paths_file, training), (args.value_paths_file, evaluation)):
        if given is not None and given.factors is None:
            raise InputError(f"paths file {file}: the file gives no factors; the {type(model).__name__} reads its state "
                             f"({', '.join(model.factor_names)}): add 'factors' (paths x days x "
                             f"{len(model.factor_names)}).")
    key = jax.random.key(settings.seed)
    if training is None:
        training = model_paths(model, inputs.forward_curve, settings.paths, jax.random.fold_in(key, 11))
    external = evaluation is not None
    if evaluation is None:
        evaluation = model_paths(model, inputs.forward_curve, settings.paths, jax.random.fold_in(key, 13))
    result = value_on_model(model, inputs, training, evaluation, nodes=args.lsmc_nodes, degree=degree, seed=settings.seed,
                            train_steps=args.train_steps, train_paths=args.train_paths, external=external,
                            progress=settings.progress)
    policy_path = args.json.with_suffix(".policy.eqx")
    policy = state_policy_bytes(result.pop("policy"))
    result["attachments"] = {policy_path.name: sha256(policy)}
    written = ", ".join(map(str, publish({policy_path: policy, args.json: json_bytes(result)})))
    print(f"storage on {result['price_model']}: intrinsic {result['intrinsic_lp']:,.0f}, rolling intrinsic "
          f"{result['rolling_intrinsic'] or float('nan'):,.0f}, LSMC {result['lsmc_out_of_sample']:,.0f}, SNAPO "
          f"{result['snapo_out_of_sample']:,.0f} (start: {result['snapo_start']}; SNAPO - LSMC "
          f"{result['snapo_minus_lsmc']:,.0f} +- "
          f"{result['snapo_minus_lsmc_se']:,.0f}), dual bound {result['dual_upper_bound'] or float('nan'):,.0f} "
          f"(penalty: {result.get('dual_penalty_choice') or 'none'})")
    print(f"  written: {written}")
    for warning in result["warnings"]:
        print(f"snapo: warning: {warning}", file=sys.stderr)
    return 0
