"""The command-line options that name a process and its chain (`--process`, the CPP flags,
`--set`, tolerances, solvers, effects), shared by every `snapo pharma` verb."""

import argparse

from snapo_ode.cli import number, positive

from ._process_file import CPP_RANGES


def add_chain_arguments(parser: argparse.ArgumentParser) -> None:
    """The process, CPP values, solver tolerances and effects."""
    parser.add_argument("--process", metavar="FILE", help="a process file (YAML, docs/pharma.md) or the name of a "
                        "shipped one (api_chain, antisolvent_route); its units, CPPs and CQAs are the file's; "
                        "default: api_chain")
    parser.add_argument("--set", action="append", default=[], metavar="NAME=VALUE", dest="settings",
                        help="set any CPP of the process by its name or target unit.parameter (with api_chain: "
                             "r1_temperature=315 or r1.temperature=315) or a physical parameter as "
                             "unit.parameter (crystallizer.growth_rate=6e-8); the value may carry a unit ('0.5 h'); "
                             "repeatable")
    for spec in CPP_RANGES:
        parser.add_argument(f"--{spec.name.replace('_', '-')}", type=number(), default=None,
                            help=f"api_chain's CPP {spec.name}: {spec.description} [{spec.unit}] (nominal "
                                 f"{spec.nominal:g}, PAR {spec.par[0]:g}-{spec.par[1]:g}); another process's "
                                 "CPPs: --set")
    parser.add_argument("--rtol", type=positive(1), default=1e-8, help="relative tolerance of every unit's solve")
    parser.add_argument("--atol", type=positive(), default=1e-10, help="absolute tolerance (scaled states)")
    parser.add_argument("--solver", default="rodas5", help="of the process's reactors (the stiff units): rodas5 "
                        "(default), rodas4, kvaerno5, kvaerno4 or kvaerno3")
    parser.add_argument("--nonstiff-solver", default="tsit5", help="of the crystallizer and the dryer: tsit5, "
                        "dopri5 or a stiff solver's name")
    parser.add_argument("--without", action="append", default=[], metavar="EFFECT",
                        help="leave an effect out (repeatable)")


def chain_from_args(args):
    """The chain and its inputs from parsed arguments (`--process`, the CPP flags, `--set`),
    validated before any compile."""
    from ._chain import CHAIN_SOLVER, PHARMA_EFFECTS, PharmaChain, chain_method
    from ._settings import settings_values

    solver = CHAIN_SOLVER.replace(rtol=args.rtol, atol=args.atol, solver=chain_method(args.solver),
                                  nonstiff_solver=chain_method(args.nonstiff_solver, "nonstiff_solver"))
    scene = PHARMA_EFFECTS.scene(without=args.without)
    chain = PharmaChain(scene=scene, solver=solver, process=args.process)
    flags = {spec.name: getattr(args, spec.name) for spec in CPP_RANGES if getattr(args, spec.name) is not None}
    cpps, physical = settings_values(chain.process, flags, args.settings)
    return chain, chain.inputs(chain.cpps(**cpps), physical=chain.physical(**physical))
