"""Reliability III: nothing silent or unsafe. A checkpoint resumes only on the inputs it was
trained on, byte for byte, and only when its own bytes are intact; a user's text is text in a
report's HTML and PDF, never markup; an output never replaces what the run did not create, and a
path that cannot hold a result is refused before any work; the terminal gets escaped text in any
locale; a signal ends a run with its exit code at any phase."""

import io
import json
import os
import pathlib
import signal
import subprocess
import sys
from html.parser import HTMLParser

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import pytest

import snapo_ode
from snapo_ode import Bullets, Figure, Heading, Highlights, Paragraph, Report, Section, Table, Value, write_report
from snapo_ode.cli import CommandLine, main, publish_report

ROOT = pathlib.Path(__file__).resolve().parents[1]
HOSTILE = "</style><script>alert(1)</script><img src=x onerror=alert(2)>{{7*7}} \"q' &amp; \x1b[31mred\x1b[0m"
RENDERED_TAGS = {"html", "head", "meta", "title", "style", "body", "h1", "h2", "h3", "p", "div", "strong", "ul",
                 "li", "nav", "ol", "a", "section", "table", "caption", "thead", "tbody", "tr", "th", "td", "span",
                 "figure", "img", "figcaption"}


def error_of(argv, capsys, code=2, plugins=None) -> str:
    assert main(argv, plugins=plugins) == code
    err = capsys.readouterr().err
    assert err.startswith("snapo: error: ") and err.count("\n") == 1, err
    return err


class Markup(HTMLParser):
    """The tags, attributes and text of a page, as a browser's parser splits them."""

    def __init__(self):
        super().__init__(convert_charrefs=True)
        self.tags, self.attributes, self.text, self.style = [], [], [], []
        self._in_style = False

    def handle_starttag(self, tag, attrs):
        self.tags.append(tag)
        self.attributes.extend(name for name, _ in attrs)
        self._in_style = tag == "style"

    def handle_endtag(self, tag):
        self._in_style = False

    def handle_data(self, data):
        (self.style if self._in_style else self.text).append(data)


def markup_of(page: str) -> Markup:
    parsed = Markup()
    parsed.feed(page)
    parsed.close()
    return parsed


def assert_inert(page: str, hostile: str = HOSTILE) -> Markup:
    """`page` holds only the renderer's own tags and attributes, one figure's image, one style
    sheet without markup, and `hostile` as text."""
    parsed = markup_of(page)
    assert set(parsed.tags) <= RENDERED_TAGS and "script" not in parsed.tags, set(parsed.tags) - RENDERED_TAGS
    assert not [name for name in parsed.attributes if name.startswith("on")]
    assert parsed.tags.count("style") == 1 and "<" not in "".join(parsed.style)
    assert hostile in "".join(parsed.text)
    return parsed


def hostile_report() -> Report:
    """A report whose every text a user can name holds `HOSTILE`."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    data = {"name": HOSTILE, "number": 1.5, HOSTILE: HOSTILE, "rows": [{"unit": HOSTILE, "x": 2.5}]}
    figure, axis = plt.subplots(figsize=(2, 1))
    axis.plot([0, 1], [0, 1])
    return Report(
        name=HOSTILE, title=HOSTILE, data=data, provenance=snapo_ode.provenance({HOSTILE: data}),
        subtitle=(HOSTILE, Value(("name",)), HOSTILE), warnings=(HOSTILE,),
        sections=(Section(HOSTILE, (
            Heading(HOSTILE), Paragraph((HOSTILE, Value(("number",), ".2f", HOSTILE)), "finding"),
            Bullets(((HOSTILE, Value((HOSTILE,))),)),
            Highlights(((HOSTILE, Value(("number",), ".1f", HOSTILE), (HOSTILE,)),)),
            Table((HOSTILE, "x"), ((Value(("rows", 0, "unit")), Value(("rows", 0, "x"))), (HOSTILE, (HOSTILE,))),
                  (HOSTILE,), csv="rows.csv"),
            Figure.from_matplotlib(figure, (HOSTILE,), HOSTILE))),),
        csv={"extra.csv": [[HOSTILE], [HOSTILE]]})


def test_a_users_text_in_every_field_of_a_report_is_text(tmp_path):
    out = tmp_path / "report"
    write_report(out, hostile_report(), pdf="skip")
    page = (out / "report.html").read_text()
    parsed = assert_inert(page)
    shown = "".join(parsed.text)
    # title, heading, section, TOC, subtitle x2, value, paragraph, unit x2, bullet, card, table x4, caption x2, warning
    assert shown.count(HOSTILE) >= 15
    assert json.loads((out / "report.json").read_text())["name"] == HOSTILE  # the JSON keeps the text as given
    css = "".join(parsed.style)
    assert "\\00003c" in css and "\\000022" in css  # the title in the page header: escaped in its CSS string


@pytest.mark.chromium
@pytest.mark.skipif(snapo_ode.find_chromium() is None, reason="no headless Chromium (Debian package chromium)")
def test_the_pdf_shows_a_users_text_as_text(tmp_path):
    import pypdf

    out = tmp_path / "report"
    write_report(out, hostile_report(), pdf="require")
    text = " ".join(page.extract_text() for page in pypdf.PdfReader(out / "report.pdf").pages)
    assert "</script>" in text and "onerror" in text  # printed as text, not run as script


# A command that stands in for a run: a gc callback sends SIGTERM while the collector runs it (as
# one lands while JAX's callback frees XLA buffers), then the "run" works on; `sys.argv[1]` says
# what happens after the first signal.
SIGNAL_SCRIPT = """
import gc, os, signal, sys, time
from snapo_ode._runtime.exits import ended

def during_gc(phase, info):
    if phase == "start" and not sent:
        sent.append(1)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(0.01)  # the handler runs here, inside the callback

sent = []

def run():
    if sys.argv[1] == "gc":
        gc.callbacks.append(during_gc)
        gc.collect()
        gc.callbacks.remove(during_gc)
        for _ in range(200):  # the work goes on: the signal must stop it
            time.sleep(0.01)
        print("finished")
        return 0
    try:  # "twice": a second Ctrl-C during the first one's cleanup
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(5)
    finally:
        os.kill(os.getpid(), signal.SIGINT)
        time.sleep(0.1)
        open(sys.argv[2], "w").write("checkpoint")  # the cleanup finishes
    return 0

sys.exit(ended(run, checkpoint=sys.argv[2], leave=True))
"""


def _run_signal_script(tmp_path, case):
    checkpoint = tmp_path / "run.checkpoint.eqx"
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # not inherited as ignored
    try:
        done = subprocess.run([sys.executable, "-c", SIGNAL_SCRIPT, case, str(checkpoint)], capture_output=True,
                              text=True, timeout=120, env={**os.environ, "PYTHONPATH": str(ROOT)})
    finally:
        signal.signal(signal.SIGINT, previous)
    return done, checkpoint


def test_sigterm_landing_in_a_gc_callback_still_ends_the_run(tmp_path):
    done, _ = _run_signal_script(tmp_path, "gc")
    assert done.returncode == 143, done.stderr
    assert "finished" not in done.stdout and "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
    assert done.stderr.strip().splitlines() == ["snapo: interrupted by SIGTERM; no result was written"]


def test_a_second_ctrl_c_during_the_cleanup_ends_quietly_with_the_checkpoint(tmp_path):
    done, checkpoint = _run_signal_script(tmp_path, "twice")
    assert done.returncode == 130, done.stderr
    assert checkpoint.read_text() == "checkpoint"
    assert done.stderr.strip().splitlines() == [
        f"snapo: interrupted by SIGINT; the training so far is in {str(checkpoint)!r}: run the same command with "
        "--resume to go on"]


def quadratic(params):
    return jnp.sum((params["x"] - 1.0) ** 2), {}


def test_a_checkpoint_whose_bytes_changed_is_refused_as_corrupt(tmp_path):
    path = tmp_path / "run.ckpt"
    snapo_ode.train(quadratic, {"x": jnp.zeros(3)}, steps=4, progress=False, checkpoint_path=path)
    header, payload = path.read_bytes().split(b"\n", 1)
    like = {"x": np.zeros(3)}
    buffer = io.BytesIO(payload)
    best = eqx.tree_deserialise_leaves(buffer, like)
    # Every parameter scaled by 1.01, the file otherwise as written: a plausible checkpoint, not this one.
    scaled = io.BytesIO()
    eqx.tree_serialise_leaves(scaled, jax.tree.map(lambda leaf: leaf * 1.01, best))
    path.write_bytes(header + b"\n" + scaled.getvalue() + buffer.read())
    with pytest.raises(snapo_ode.InputError, match=r"run.ckpt' is corrupt: its checksum .* does not match"):
        snapo_ode.train(quadratic, {"x": jnp.zeros(3)}, steps=4, progress=False, checkpoint_path=path, resume=True)
    path.write_bytes(json.dumps({k: v for k, v in json.loads(header).items() if k != "checksum"}).encode() + b"\n"
                     + payload)
    with pytest.raises(snapo_ode.InputError, match="has no checksum"):
        snapo_ode.load_checkpoint(path, like)


def test_a_checkpoint_resumes_only_on_the_input_files_it_was_trained_on(tmp_path):
    from snapo_ode._fingerprint import reading_files

    scenarios = tmp_path / "scenarios.csv"
    scenarios.write_text("scenario,time,value\n0,0,1.0\n")
    path = tmp_path / "run.ckpt"
    settings = dict(steps=3, progress=False, checkpoint_path=path)
    with reading_files({"--scenarios": scenarios}):
        snapo_ode.train(quadratic, {"x": jnp.zeros(2)}, **settings)
        assert snapo_ode.train(quadratic, {"x": jnp.zeros(2)}, resume=True, **settings).steps_run == 3
    scenarios.write_text("scenario,time,value\n0,0,1.01\n")  # what the run makes of it need not show the change
    with reading_files({"--scenarios": scenarios}), pytest.raises(snapo_ode.InputError,
                                                                  match="its file --scenarios differ"):
        snapo_ode.train(quadratic, {"x": jnp.zeros(2)}, resume=True, **settings)
    with pytest.raises(snapo_ode.InputError, match="its file --scenarios differ"):  # and without the file
        snapo_ode.train(quadratic, {"x": jnp.zeros(2)}, resume=True, **settings)


def counting_report(calls: list):
    def register(cli: CommandLine):
        cli.report("toy", "a toy report").set_defaults(handler=lambda args: calls.append(args) or publish_report(
            args, Report(name="toy", title="Toy", data={"v": 1.0}, provenance=snapo_ode.provenance({}),
                         sections=(Section("S", (Paragraph((Value(("v",)),)),)),))))
    return register


def test_a_report_never_replaces_a_directory_holding_what_it_did_not_write(tmp_path, capsys):
    calls = []
    toy = counting_report(calls)
    out = tmp_path / "report"
    out.mkdir()
    (out / "MANIFEST.json").write_text('{"files": {}}')  # another tool's manifest
    (out / "notes.txt").write_text("mine")
    err = error_of(["report", "toy", "--no-pdf", "--out", str(out)], capsys, plugins=[toy])
    assert "holds 'notes.txt', which its MANIFEST.json does not list" in err and calls == []
    (out / "notes.txt").unlink()
    (out / "MANIFEST.json").write_text('{"written_by": "someone else", "files": {}}')
    assert "holds a MANIFEST.json that this package did not write" in error_of(
        ["report", "toy", "--no-pdf", "--out", str(out)], capsys, plugins=[toy])
    (out / "MANIFEST.json").unlink()
    assert main(["report", "toy", "--no-pdf", "--out", str(out)], plugins=[toy]) == 0  # empty: written
    assert main(["report", "toy", "--no-pdf", "--out", str(out)], plugins=[toy]) == 0  # its own: replaced
    (out / "notes.txt").write_text("mine")
    assert "holds 'notes.txt'" in error_of(["report", "toy", "--no-pdf", "--out", str(out)], capsys, plugins=[toy])
    assert (out / "notes.txt").read_text() == "mine"
    (out / "notes.txt").unlink()
    (out / "report.html").write_text("edited")
    assert "holds 'report.html', changed since the report was written" in error_of(
        ["report", "toy", "--no-pdf", "--out", str(out)], capsys, plugins=[toy])
    assert (out / "report.html").read_text() == "edited" and len(calls) == 2


def test_an_output_that_is_not_a_regular_file_is_refused_before_any_work(tmp_path, capsys):
    calls = []
    toy = counting_report(calls)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for flag, path, kind in (("--json", "/dev/null", "a character device"), ("--json", fifo, "a named pipe"),
                             ("--json", tmp_path, "a directory"), ("--out", "/dev/null", "exists and is not a")):
        err = error_of(["report", "toy", "--no-pdf", "--out", str(tmp_path / "r"), flag, str(path)], capsys,
                       plugins=[toy])
        assert f"{flag} = {str(path)!r}" in err and kind in err, err
    assert "--checkpoint = '/dev/null' is a character device" in error_of(
        ["gas", "--checkpoint", "/dev/null", "--out", str(tmp_path / "g")], capsys)
    assert calls == [] and not (tmp_path / "r").exists()


def test_escape_sequences_in_a_users_file_reach_the_terminal_escaped(tmp_path, capsys):
    from finance import gas_storage as gs

    facility = tmp_path / "facility.json"
    facility.write_text(json.dumps({**gs.sample_facility(), "cap\x1b]0;owned\x07\x1b[2Jacity": 1}))
    err = error_of(["gas", "--facility", str(facility), "--out", str(tmp_path / "g")], capsys)
    assert "cap\\x1b]0;owned\\x07\\x1b[2Jacity" in err and "\x1b" not in err and "\x07" not in err


LOCALE_SCRIPT = """
import sys
from snapo_ode import Paragraph, Report, Section, Value, provenance
from snapo_ode.cli import main, publish_report

def register(cli):
    cli.report("toy", "a toy report").set_defaults(handler=lambda args: publish_report(args, Report(
        name="toy", title="Toy \\u2192 \\u00e9t\\u00e9", data={"v": 1.0}, provenance=provenance({}),
        sections=(Section("S", (Paragraph((Value(("v",)),)),)),))))

sys.exit(main(["report", "toy", "--no-pdf", "--out", sys.argv[1]], plugins=[register]))
"""


@pytest.mark.parametrize("encoding", ["ascii", "latin-1"])
def test_any_locale_prints_the_written_paths_after_the_result(tmp_path, encoding):
    out = tmp_path / "r\u00e9sultat \u2192 \u6f22"
    environment = {**os.environ, "PYTHONIOENCODING": encoding, "LANG": "C", "LC_ALL": "C", "PYTHONPATH": str(ROOT)}
    done = subprocess.run([sys.executable, "-c", LOCALE_SCRIPT, str(out)], capture_output=True, env=environment,
                          timeout=120)
    assert done.returncode == 0 and done.stderr == b"", done.stderr
    assert (out / "report.html").exists()
    lines = done.stdout.decode(encoding).splitlines()
    assert f"written: {out / 'report.html'}".encode(encoding, "backslashreplace").decode(encoding) in lines


def _scenario_csv(path, market, shift=0.0):
    """Four annual scenarios of the built-in fund's variables, one rate moved by `shift`."""
    names = ["zero_rate_1", "zero_rate_10", *(f"equity_{name}" for name in market.equity_names), "cpi"]
    rows = [(s, year, name, {"zero_rate_1": 0.02 + 0.001 * year * s + (shift if (s, year) == (1, 1) else 0.0),
                             "zero_rate_10": 0.03, "cpi": 1.02 ** year}.get(name, 1.1 ** year * (1 + 0.01 * s * year)))
            for s in range(4) for year in range(2) for name in names]
    path.write_text("scenario,time,variable,value\n" + "".join(f"{s},{t},{v},{x!r}\n" for s, t, v, x in rows))
    return path


def test_snapo_alm_resumes_only_on_the_scenario_file_it_trained_on(tmp_path, capsys):
    from finance import alm

    market = alm.load_fund(alm.sample_fund_path()).market
    run = ["alm", "--horizon-months", "3", "--train-steps", "1", "--no-progress", "--out", str(tmp_path / "o")]
    assert main([*run, "--scenarios", str(_scenario_csv(tmp_path / "a.csv", market))]) == 0
    other = _scenario_csv(tmp_path / "b.csv", market, shift=1e-4)
    err = error_of([*run, "--scenarios", str(other), "--resume"], capsys)
    assert "is of another run: its file --scenarios differ" in err


def hostile_directory(tmp_path) -> pathlib.Path:
    """A directory whose path holds `HOSTILE` (its slashes make it nested): a user's file put
    there shows the text wherever its path is shown (the command line in the provenance)."""
    directory = tmp_path / f"in{HOSTILE}"
    directory.mkdir(parents=True)
    assert HOSTILE in str(directory)
    return directory


def yaml_edited(path: pathlib.Path, edit) -> str:
    """The YAML file at `path`, read, changed by `edit(data)`, written again as text."""
    from ruamel.yaml import YAML

    yaml = YAML(typ="safe", pure=True)
    data = yaml.load(path.read_text())
    edit(data)
    text = io.StringIO()
    yaml.dump(data, text)
    return text.getvalue()


def assert_report_inert(out: pathlib.Path) -> None:
    assert_inert((out / "report.html").read_text())
    if (out / "report.pdf").exists():
        import pypdf

        text = " ".join(page.extract_text() for page in pypdf.PdfReader(out / "report.pdf").pages)
        assert "</script>" in text


@pytest.mark.slow
def test_pharma_report_shows_hostile_process_names_and_descriptions_as_text(tmp_path):
    built_in = ROOT / "chemistry" / "pharma" / "processes" / "api_chain.yaml"

    def hostile(process):
        process["mechanism"]["file"] = str((built_in.parent / process["mechanism"]["file"]).resolve())
        process["name"] = process["description"] = HOSTILE
        for entry in process["cpps"] + process["cqas"]:
            entry["description"] = HOSTILE

    path = hostile_directory(tmp_path) / "process.yaml"
    path.write_text(yaml_edited(built_in, hostile))
    out = tmp_path / "report"
    assert main(["report", "pharma", "--process", str(path), "--out", str(out), "--rtol", "1e-10", "--atol", "1e-12",
                 "--points", "5", "--verify-points", "4", "--samples", "47", "--curvature-points", "2",
                 "--surrogate-samples", "1024", "--repeats", "1", "--no-progress"]) == 0
    assert_report_inert(out)


@pytest.mark.slow
def test_alm_report_shows_a_hostile_fund_name_and_path_as_text(tmp_path):
    from finance import alm

    built_in = pathlib.Path(alm.sample_fund_path())
    directory = hostile_directory(tmp_path)
    (directory / "fund.yaml").write_text(yaml_edited(built_in, lambda fund: fund.update(name=HOSTILE)))
    liabilities = "alm_liabilities.csv"  # the built-in fund's, beside its file
    (directory / liabilities).write_bytes((built_in.parent / liabilities).read_bytes())
    out = tmp_path / "report"
    assert main(["report", "alm", "--fund", str(directory / "fund.yaml"), "--out", str(out), "--paths", "64",
                 "--horizon-months", "24", "--train-steps", "5", "--train-paths", "32", "--no-progress"]) == 0
    assert_report_inert(out)


@pytest.mark.slow
def test_gas_report_shows_hostile_file_paths_as_text(tmp_path):
    from finance import gas_storage as gs

    directory = hostile_directory(tmp_path)
    (directory / "facility.json").write_text(json.dumps(gs.sample_facility()))
    curve = gs.sample_curve()
    (directory / "curve.csv").write_text("day,price\n" + "".join(f"{day},{price!r}\n" for day, price in
                                                                 enumerate(np.asarray(curve).tolist())))
    out = tmp_path / "report"
    assert main(["report", "gas", "--facility", str(directory / "facility.json"), "--curve",
                 str(directory / "curve.csv"), "--out", str(out), "--train-steps", "30", "--no-progress"]) == 0
    assert_report_inert(out)
