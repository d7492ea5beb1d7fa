"""CLI verbs of the pension-fund ALM study: `snapo alm` and `snapo bench alm`.

Heavy imports (JAX, the model) happen inside the handlers, so `snapo --help` stays quick.
"""

from snapo_ode.cli import CommandLine


def _alm(args) -> int:
    from snapo_ode import atomic_write_json

    from .alm._study import run_alm

    payload = run_alm(args.risk_factors, n_paths=args.paths, horizon_months=args.horizon_months,
                      bump=args.bump, train_steps=args.train_steps, train_paths=args.train_paths,
                      seed=args.seed, progress=not args.no_progress)
    atomic_write_json(args.json, payload)
    ratio = payload["funding_ratio"]
    print(f"N = {payload['n_risk_factors']}: objective {payload['objective']:.6f} (smooth "
          f"{payload['objective_smooth']:.6f}); funding ratio at {payload['horizon_months']} months "
          f"mean {ratio['mean']:.3f}, 5% {ratio['p05']:.3f}")
    for name, baseline in payload["baselines"].items():
        print(f"  {name}: objective {baseline['objective']:.6f}")
    print(f"adjoint {payload['adjoint_seconds']:.4f} s", end="")
    if payload["speedup"] is not None:
        print(f"; bump {payload['bump_seconds']:.3f} s (speedup {payload['speedup']:.0f}x, max rel "
              f"diff {payload['max_rel_diff']:.1e}); forward mode "
              f"{payload['forward_mode_seconds']:.3f} s", end="")
    print(f"\nwrote {args.json}")
    return 0


def _bench(args) -> int:
    from .alm._bench import format_table, scaling_rows, write_scaling

    rows = scaling_rows(args.risk_factors, n_paths=args.paths, horizon_months=args.horizon_months,
                        repeats=args.repeats, seed=args.seed, progress=not args.no_progress)
    print(format_table(rows))
    csv_path, png_path = write_scaling(rows, args.out)
    print(f"wrote {csv_path} and {png_path}")
    return 0


def register_alm(cli: CommandLine) -> None:
    """Add `snapo alm` and `snapo bench alm`."""
    parser = cli.command("alm", "pension-fund ALM: train the rebalancing policy and report the "
                                "sensitivities to every risk factor (one reverse pass)")
    parser.add_argument("--risk-factors", type=int, default=100, metavar="N",
                        help="number of reported risk factors, >= 9 (default 100)")
    parser.add_argument("--paths", type=int, default=1000, help="Monte Carlo paths (default 1000)")
    parser.add_argument("--horizon-months", type=int, default=120, metavar="H",
                        help="horizon in months, 1 to 600 (default 120)")
    parser.add_argument("--bump", action="store_true",
                        help="also run central bump-and-revalue and forward mode, and compare")
    parser.add_argument("--train-steps", type=int, default=0, metavar="S",
                        help="policy training steps (default 0: an untrained policy)")
    parser.add_argument("--train-paths", type=int, default=256, help="paths per training step")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--no-progress", action="store_true", help="hide progress bars")
    parser.add_argument("--json", required=True, metavar="OUT", help="where to write the results")
    parser.set_defaults(handler=_alm)

    bench = cli.bench("alm", "sensitivity cost against the number of risk factors: adjoint vs "
                             "batched bump-and-revalue vs forward mode")
    bench.add_argument("--risk-factors", type=int, nargs="+",
                       default=[10, 50, 100, 500, 1000, 2000], metavar="N")
    bench.add_argument("--paths", type=int, default=128, help="paths (default 128)")
    bench.add_argument("--horizon-months", type=int, default=120, metavar="H")
    bench.add_argument("--repeats", type=int, default=3, help="timed runs per method")
    bench.add_argument("--seed", type=int, default=0)
    bench.add_argument("--no-progress", action="store_true")
    bench.add_argument("--out", default="snapo-out", help="output directory (default ./snapo-out)")
    bench.set_defaults(handler=_bench)
