"""CLI verb of the pendulum study: `snapo pendulum`.

Heavy imports (JAX, the model, Gymnasium) happen inside the handler, so `snapo --help` stays quick.
"""

from snapo_ode.cli import count, seed, CommandLine


def _pendulum(args) -> int:
    from ._study import run_pendulum
    from ._training import TrainingSettings

    settings = TrainingSettings(batch=args.batch)
    study = run_pendulum(args.train_steps, eval_episodes=args.eval_episodes, eval_seed=args.eval_seed,
                         seed=args.seed, settings=settings, policy_path=args.json.with_suffix(".policy.eqx"),
                         progress=args.progress)
    study.write_json(args.json)
    print(study.summary())
    print(f"written: {args.json}, {study.policy_path}")
    return 0


def register_pendulum(cli: CommandLine) -> None:
    """Add `snapo pendulum`."""
    defaults = {"steps": 600, "batch": 64}
    parser = cli.command("pendulum", "Gymnasium's Pendulum-v1: train a swing-up policy through our differentiable "
                                     "model with the angle as a periodic state, evaluate it on Gymnasium's own "
                                     "environment, next to the same training without the periodic treatment")
    parser.add_argument("--train-steps", type=count(), default=defaults["steps"], metavar="N",
                        help=f"optimisation steps (default {defaults['steps']})")
    parser.add_argument("--batch", type=count(), default=defaults["batch"], metavar="B",
                        help=f"initial states per step (default {defaults['batch']})")
    parser.add_argument("--eval-episodes", type=count(), default=100, metavar="E",
                        help="Gymnasium episodes of the evaluation (default 100)")
    parser.add_argument("--eval-seed", type=seed, default=0, metavar="S",
                        help="seed of the first evaluation reset (default 0)")
    parser.set_defaults(handler=_pendulum)
