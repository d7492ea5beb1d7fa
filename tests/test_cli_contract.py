"""The CLI contract over every registered verb and bench (issue 34, item 3), read from the parser
tree of the installed plugins: each runnable verb has a handler, the common options and a JSON
name (its result is always written, `OUT/NAME.json` unless `--json` says where), and every bench
writes `bench_NAME.json` beside its CSV. (Running verbs is what their own tests do.)"""

import argparse

from snapo_ode.cli import build, parse

COMMON = {"--out", "--json", "--no-progress", "--seed", "--debug"}


def _leaves(parser: argparse.ArgumentParser, path=()):
    """(path, parser) of every runnable verb: the parsers without sub-verbs."""
    groups = [action for action in parser._actions if isinstance(action, argparse._SubParsersAction)]
    if not groups:
        yield path, parser
        return
    for group in groups:
        for name, child in group.choices.items():
            yield from _leaves(child, (*path, name))


def test_every_verb_and_bench_takes_the_common_options_and_writes_its_json():
    leaves = dict(_leaves(build().parser))
    assert {("demo",), ("gas",), ("alm",), ("bench", "gas-family"), ("bench", "alm"), ("bench", "pharma"),
            ("bench", "kinetics"), ("pharma", "sensitivities"), ("kinetics", "sweep")} <= set(leaves)
    for path, parser in leaves.items():
        options = {option for action in parser._actions for option in action.option_strings}
        assert COMMON <= options, (path, COMMON - options)
        assert callable(parser.get_default("handler")), path
        json_name = parser.get_default("json_name")
        if path[0] == "bench":
            assert json_name == f"bench_{path[1].replace('-', '_')}.json", path
        else:
            assert json_name.endswith(".json"), path


def test_json_goes_where_it_is_told_and_defaults_into_out(tmp_path):
    cli = build()
    told = parse(cli, ["bench", "gas-family", "--json", str(tmp_path / "x.json")])
    assert told.json == tmp_path / "x.json"
    default = parse(cli, ["bench", "gas-family", "--out", str(tmp_path)])
    assert default.json == tmp_path / "bench_gas_family.json"
