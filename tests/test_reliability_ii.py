"""Reliability II (issue 33): no wrong result from a stale checkpoint or a shared cache, no input
that exhausts memory, every failure a one-line exit 2 (user), 3 (solve) or 4 (environment)."""

import argparse
import errno
import json
import os
import pathlib
import re
import signal
import stat
import subprocess
import sys
import time

import pytest

import snapo_ode

from finance import gas_storage as gs
from snapo_ode.cli import build, main


def error_of(argv, capsys, code=2) -> str:
    assert main(argv) == code
    err = capsys.readouterr().err
    assert err.startswith("snapo: error: ") and err.count("\n") == 1, err
    return err


def test_resume_refuses_the_checkpoint_of_another_facility_or_seed(tmp_path, capsys):
    gas = ["gas", "--train-steps", "3", "--no-progress", "--out", str(tmp_path / "gas")]
    assert main(gas) == 0
    other = dict(gs.sample_facility(), capacity=2_000_000.0, terminal_inventory_min=0.0)
    (tmp_path / "other.json").write_text(json.dumps(other))
    err = error_of([*gas, "--facility", str(tmp_path / "other.json"), "--resume"], capsys)
    assert re.search("is of another run: its [a-z ,-]*inputs[a-z ,-]* differ", err), err  # with "file --facility"
    assert main([*gas, "--resume"]) == 0  # its own run resumes
    alm = ["alm", "--risk-factors", "10", "--paths", "8", "--horizon-months", "3", "--train-steps", "3",
           "--train-paths", "8", "--no-progress", "--out", str(tmp_path / "alm")]
    assert main(alm) == 0
    assert re.search("its [a-z ,]*key[a-z ,]* differ", error_of([*alm, "--seed", "1", "--resume"], capsys))


CACHE_SCRIPT = """
import sys, warnings, jax, jax.numpy as jnp, snapo_ode
snapo_ode.configure(sys.argv[1])
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    value = float(jax.jit(lambda x: jnp.sum(jnp.sin(x) * float(sys.argv[2])))(jnp.arange(8.0)))
print(value, sum("failed its seal check" in str(w.message) for w in caught))
"""


def _cached_value(directory, constant):
    out = subprocess.run([sys.executable, "-c", CACHE_SCRIPT, str(directory), str(constant)], capture_output=True,
                         text=True, check=True).stdout.split()
    return float(out[0]), int(out[1])


def test_a_swapped_or_corrupt_cache_entry_is_rebuilt_and_replaced(tmp_path):
    cache = tmp_path / "cache"
    one, two = _cached_value(cache, 1.0)[0], _cached_value(cache, 2.0)[0]
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    first, second = sorted(cache.glob("jit__lambda*"))
    a, b = first.read_bytes(), second.read_bytes()
    first.write_bytes(b)  # swapped: each a valid entry of the other key
    second.write_bytes(a)
    values = {_cached_value(cache, 1.0), _cached_value(cache, 2.0)}
    assert values == {(one, 1), (two, 1)}  # the right values, each swapped entry refused once
    assert {_cached_value(cache, 1.0), _cached_value(cache, 2.0)} == {(one, 0), (two, 0)}  # and replaced
    first.write_bytes(first.read_bytes()[:-5])  # truncated
    assert _cached_value(cache, 1.0)[1] + _cached_value(cache, 2.0)[1] == 1


SEAL_KEY_SCRIPT = """
import sys, time
from snapo_ode._platform.cache_trust import directory_secret
start = float(sys.argv[2])
while time.time() < start:
    pass
print(directory_secret(sys.argv[1]).hex())
"""


def test_processes_that_open_a_new_cache_at_once_share_one_whole_seal_key(tmp_path):
    # Before: the first process created the key file empty and wrote it after; the others read it
    # in between and refused the cache ("not a private 32-byte file"), both pytest workers on a
    # clean machine among them (18 of 20 such races failed).
    for trial in range(4):
        cache = tmp_path / f"cache{trial}"
        cache.mkdir(mode=0o700)
        start = time.time() + 1.0
        runs = [subprocess.Popen([sys.executable, "-c", SEAL_KEY_SCRIPT, str(cache), str(start)], text=True,
                                 stdout=subprocess.PIPE, stderr=subprocess.PIPE) for _ in range(6)]
        outputs = [run.communicate() for run in runs]
        assert all(run.returncode == 0 for run in runs), [err[-300:] for _, err in outputs]
        assert len({out for out, _ in outputs}) == 1 and len(bytes.fromhex(outputs[0][0].strip())) == 32
        assert sorted(path.name for path in cache.iterdir()) == [".snapo-seal-key"]  # no temporary left


def test_a_cache_others_can_write_or_that_is_a_file_is_refused(tmp_path, capsys, monkeypatch):
    shared = tmp_path / "shared"
    shared.mkdir()
    shared.chmod(0o777)
    with pytest.raises(snapo_ode.CacheUnavailable, match="writable by others"):
        snapo_ode.configure(shared)
    monkeypatch.setenv("SNAPO_CACHE_DIR", str(shared))
    assert "chmod go-w" in error_of(["gas", "--train-steps", "1", "--out", str(tmp_path / "o")], capsys, 4)
    a_file = tmp_path / "file"
    a_file.write_text("x")
    monkeypatch.setenv("SNAPO_CACHE_DIR", str(a_file))
    assert "set SNAPO_CACHE_DIR to a writable directory" in error_of(
        ["gas", "--train-steps", "1", "--out", str(tmp_path / "o")], capsys, 4)
    monkeypatch.delenv("SNAPO_CACHE_DIR")
    monkeypatch.delenv("XDG_CACHE_HOME", raising=False)
    monkeypatch.setenv("HOME", str(a_file / "home"))  # no cache can be made under a file: a read-only HOME
    assert main(["gas", "--train-steps", "1", "--no-progress", "--out", str(tmp_path / "o")]) == 0
    assert "snapo: warning: the compilation cache" in capsys.readouterr().err


@pytest.mark.parametrize("change, message", [
    ({"capacity": "1e6"}, "capacity = '1e6': Input should be a valid number"),
    ({"fuel_loss": True}, "fuel_loss = True: Input should be a valid number"),
    ({"capacity": 1e308}, "capacity = 1e+308 is outside the allowed range (0, 1e+12]"),
    ({"injection_cost": 1e308}, "injection_cost = 1e+308 is outside the allowed range [0, 1e+06]"),
    ({"rate": float("nan")}, "NaN is not a JSON number"),
    ({"injection_ratchet": [[0, 1, 2], [1, 1]]}, "injection_ratchet.0 = [0, 1, 2]: List should have at most 2"),
])
def test_facility_files_are_read_strictly(tmp_path, change, message):
    path = tmp_path / "facility.json"
    path.write_text(json.dumps({**gs.sample_facility(), **change}, indent=1))
    with pytest.raises(snapo_ode.InputError, match=re.escape(message)):
        gs.make_inputs(gs.load_facility(path), gs.sample_curve())


def test_duplicate_keys_and_deep_nesting_are_refused(tmp_path):
    text = json.dumps(gs.sample_facility(), indent=1)
    duplicate = tmp_path / "duplicate.json"
    duplicate.write_text(text[:-1] + ', "capacity": 5\n}')
    with pytest.raises(snapo_ode.InputError, match="the key 'capacity' is given twice"):
        gs.load_facility(duplicate)
    deep = tmp_path / "deep.json"
    deep.write_text(text[:-1] + ', "injection_ratchet": ' + "[" * 100_000 + "]" * 100_000 + "\n}")
    with pytest.raises(snapo_ode.InputError, match="nested too deeply"):
        gs.load_facility(deep)


@pytest.mark.parametrize("price, message", [
    ("3_2277", "price = '3_2277' is not a decimal number"), ("true", "price = 'true' is not a decimal number"),
    ("nan", "price = 'nan' is not a decimal number"), ("0x10", "price = '0x10' is not a decimal number"),
    ("1e20", "forward_curve (price)[0] = 1e+20 is outside the allowed range [-1e+06, 1e+06]"),
])
def test_curve_numbers_are_decimals_of_bounded_size(tmp_path, price, message):
    path = tmp_path / "curve.csv"
    path.write_text(f"day,price\n0,{price}\n1,3.0\n")
    with pytest.raises(snapo_ode.InputError, match=re.escape(message)):
        gs.make_inputs(gs.sample_facility(), gs.load_curve(path))


def test_yaml_aliases_are_refused_before_cantera_reads_the_file(tmp_path, capsys):
    laughs = tmp_path / "laughs.yaml"
    lines = ['a: &a ["lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol", "lol"]']
    lines += [f"{b}: &{b} [{', '.join([f'*{a}'] * 9)}]" for a, b in zip("abcdefgh", "bcdefghi")]
    laughs.write_text("\n".join(lines) + "\nphases:\n- name: gas\n  thermo: ideal-gas\n  species: [gri30.yaml/species: "
                      "[H2, O2]]\n  kinetics: gas\n  reactions: none\n")
    err = error_of(["kinetics", "check", str(laughs), "--out", str(tmp_path / "k")], capsys)
    assert f"mechanism file {laughs}, line " in err and "its YAML aliases (*name) expand it past 10 times its own size" in err


def test_outputs_write_through_links_and_refuse_streams(tmp_path, capsys):
    target = tmp_path / "real.json"
    target.write_text("{}")
    link = tmp_path / "link.json"
    link.symlink_to(target)
    snapo_ode.atomic_write_json(link, {"a": 1})
    assert link.is_symlink() and json.loads(target.read_text()) == {"a": 1}
    assert "is a directory" in error_of(["gas", "--json", str(tmp_path)], capsys)
    with pytest.raises(snapo_ode.InputError, match="is a character device, not a regular file"):
        snapo_ode.atomic_write_json("/dev/null", {"a": 1})  # a result written there would be lost
    assert pathlib.Path("/dev/null").is_char_device()
    directory = tmp_path / "report-real"
    snapo_ode.publish_directory(directory, {"a.txt": b"1"})
    linked = tmp_path / "report"
    linked.symlink_to(directory)
    snapo_ode.publish_directory(linked, {"a.txt": b"2"})
    assert linked.is_symlink() and (linked / "a.txt").read_bytes() == b"2"
    assert sorted(path.name for path in tmp_path.iterdir()) == ["link.json", "real.json", "report", "report-real"]


def test_every_failure_has_its_exit_code_and_one_line(tmp_path, capsys, monkeypatch):
    from snapo_ode._platform import files
    from snapo_ode._runtime.exits import ended

    def full_disk(path, data):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    cases = [(snapo_ode.InputError("x = 1 is bad."), 2, "x = 1 is bad."),
             (RecursionError(), 2, "nested too deeply"),
             (snapo_ode.TrainingDiverged("the loss became nan at step 3; lower the learning rate", 3, None), 3,
              "lower the learning rate"),
             (OSError(errno.EROFS, "Read-only file system", "/x"), 4, "/x: Read-only file system; the file system is"),
             (MemoryError(), 4, "out of memory")]
    for error, code, message in cases:
        def fail(error=error):
            raise error
        assert ended(fail) == code
        err = capsys.readouterr().err
        assert err.startswith("snapo: error: ") and err.count("\n") == 1 and message in err, err
    monkeypatch.setattr(files, "_write_temporary", full_disk)
    err = error_of(["gas", "--train-steps", "1", "--no-progress", "--out", str(tmp_path / "full")], capsys, 4)
    assert "No space left on device; free some space" in err


@pytest.mark.parametrize("signal_number, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_sigint_and_sigterm_save_the_checkpoint_and_exit_quietly(tmp_path, signal_number, code):
    out = tmp_path / "run"
    command = [sys.executable, "-m", "snapo_ode.cli", "gas", "--train-steps", "1000000", "--no-progress",
               "--out", str(out)]
    # A test run started as a background job inherits an ignored SIGINT, and a program keeps an
    # ignored SIGINT ignored (as `nohup` wants): start the run with Ctrl-C's default disposition
    # (a handled signal is reset to the default in the child).
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True)
    finally:
        signal.signal(signal.SIGINT, previous)
    try:
        checkpoint = out / "gas.checkpoint.eqx"
        deadline = time.monotonic() + 600  # a cold cache on a loaded machine: the first compile takes minutes
        while not checkpoint.exists() and time.monotonic() < deadline and process.poll() is None:
            time.sleep(0.2)
        assert checkpoint.exists(), "no checkpoint before the deadline"
        time.sleep(0.5)  # training, not compiling: the signal lands between steps
        process.send_signal(signal_number)
        err = process.communicate(timeout=120)[1]
    finally:
        process.kill()  # never left running (and taking a core) after a failure
    assert process.returncode == code, err
    name = "SIGTERM" if signal_number == signal.SIGTERM else "SIGINT"
    assert err.strip().splitlines()[-1].startswith(f"snapo: interrupted by {name}; the training so far is in")
    assert "Traceback" not in err
    header = json.loads(checkpoint.read_bytes().split(b"\n", 1)[0])
    assert header["next_step"] >= 50 and header["steps"] == 1_000_000
    assert not [p for p in out.iterdir() if p.name.endswith(".tmp")]


def _verbs(parser, prefix=()):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _verbs(sub, (*prefix, name))
    if parser.get_default("handler") is not None:
        yield prefix, parser


def test_every_numeric_option_is_range_checked_as_it_is_parsed(capsys):
    verbs = list(_verbs(build().parser))
    assert len(verbs) > 15
    for prefix, parser in verbs:
        for action in parser._actions:
            assert action.type not in (int, float), f"snapo {' '.join(prefix)} {action.option_strings}: a bare type"
    for argv, message in ((["gas", "--paths", "-5"], "gas: argument --paths: -5 is out of range: allowed >= 1"),
                          (["bench", "gas-family", "--cases", "0"], "allowed >= 1"),
                          (["kinetics", "sweep", "--states", "0"], "allowed >= 1"),
                          (["pharma", "train", "--sharpness", "-1"], "allowed (0, inf]"),
                          (["gas", "--stochastic", "--volatility", "nan"], "'nan' is not a number"),
                          (["bench", "pharma", "--repeats", "x"], "'x' is not a whole number")):
        assert message in error_of(argv, capsys)


PRINTING_SCRIPT = """
import sys
sys.path.insert(0, sys.argv[1])
from test_report_core import toy_report
from snapo_ode.cli import main, publish_report

def register(cli):
    cli.report("toy", "a toy report").set_defaults(handler=lambda args: publish_report(args, toy_report(3000)))

sys.exit(main(["report", "toy", "--out", sys.argv[2]], plugins=[register]))
"""


# A printer that works as Chromium does: helper processes, and files of its own under $TMPDIR.
FAKE_CHROMIUM = """#!/bin/sh
mkdir -p "$TMPDIR/org.chromium.fake"
(sleep 2; touch "$TMPDIR/org.chromium.fake/late") &
touch "$TMPDIR/org.chromium.fake/started"
sleep 60
"""


def test_sigterm_while_printing_the_pdf_leaves_no_temporary_files_or_processes(tmp_path):
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    printer = tmp_path / "chromium"
    printer.write_text(FAKE_CHROMIUM)
    printer.chmod(0o755)
    tests = str(pathlib.Path(__file__).parent)
    process = subprocess.Popen([sys.executable, "-c", PRINTING_SCRIPT, tests, str(tmp_path / "report")],
                               stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "TMPDIR": str(temporary), "SNAPO_CHROMIUM": str(printer)})
    deadline = time.monotonic() + 120
    while not list(temporary.glob("snapo-pdf-*/org.chromium.fake/started")) and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(signal.SIGTERM)
    err = process.communicate(timeout=60)[1]
    assert process.returncode == 143, err
    assert err.strip().splitlines()[-1] == "snapo: interrupted by SIGTERM; no result was written"
    time.sleep(3)  # the helper would have written by now, had it survived
    assert not list(temporary.iterdir()) and not (tmp_path / "report").exists()


def test_design_space_options_are_refused_before_the_chain_is_built(tmp_path, capsys, monkeypatch):
    from chemistry.pharma import _cli

    monkeypatch.setattr(_cli, "chain_from_args", lambda args: pytest.fail("computed before the options were checked"))
    for verb in (["report", "pharma", "--no-pdf"], ["pharma", "design-space"]):
        err = error_of([*verb, "--x", "<bad>", "--out", str(tmp_path / "o")], capsys)
        assert "x = '<bad>' is not one of: 'r1_temperature'" in err
    assert "verify_points = 500" in error_of(["pharma", "design-space", "--verify-points", "500", "--out",
                                              str(tmp_path / "o")], capsys)
