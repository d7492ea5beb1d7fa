"""What a command's paths must be before it computes anything: its outputs writable without
replacing what it did not create, and its input files, whose bytes a checkpoint records."""

import os
import pathlib
import sys
from collections.abc import Mapping

from .._platform.validation import InputError

OUTPUT_OPTIONS = ("out", "json", "checkpoint")  # with every `write_*`: the paths a command writes


def check_outputs(out: pathlib.Path, outputs: Mapping[str, pathlib.Path | None], *, report: bool = False,
                  pdf: str = "skip") -> None:
    """Refuse, before any computation, outputs that could not be written: each of `outputs`
    (flag -> path, e.g. `--json`) naming anything but a regular file or a new path (a directory,
    /dev/null, a named pipe) or under an unwritable directory, `out` (`--out`) naming anything but
    a directory; for a `report`, an `out` holding anything but a report written before and
    unchanged since (the report replaces its directory whole), and Chromium as `pdf` asks."""
    from .._platform.files import check_replaceable_directory, check_writable_under, output_target

    if out.exists() and not out.is_dir():
        kind = "is an existing file" if out.is_file() else "exists and is not a directory"
        raise InputError(f"--out = {str(out)!r} {kind}; give a directory.")
    for flag, path in outputs.items():
        if path is not None:
            output_target(path, flag)
            check_writable_under(path.resolve().parent, flag)
    check_writable_under(out.resolve(), "--out")
    if report:
        check_replaceable_directory(out, "--out")
        check_pdf_printer(pdf)


def check_pdf_printer(pdf: str) -> None:
    """Before computing a report: with `pdf` "require", refuse when Chromium is missing; with
    "auto", warn at once that the PDF will be left out."""
    from .pdf import find_chromium, missing_message

    if pdf == "skip" or find_chromium() is not None:
        return
    if pdf == "require":
        raise InputError(f"--require-pdf: {missing_message()}")
    print(f"snapo: warning: report.pdf will not be written: {missing_message()}", file=sys.stderr)


def input_files(options: Mapping[str, object]) -> dict[str, pathlib.Path]:
    """The input files among a command's `options` (destination -> value): each `pathlib.Path`
    value (or list of them) naming a readable regular file, but the outputs (`OUTPUT_OPTIONS`,
    `write_*`); flag (`--scenarios`, `--files #2`) -> path."""
    files = {}
    for name, value in options.items():
        if name in OUTPUT_OPTIONS or name.startswith("write_"):
            continue
        for i, path in enumerate(value if isinstance(value, list) else [value]):
            if isinstance(path, pathlib.Path) and path.is_file() and os.access(path, os.R_OK):
                files[f"--{name.replace('_', '-')}{f' #{i + 1}' if isinstance(value, list) else ''}"] = path
    return files
