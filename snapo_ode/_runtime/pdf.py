"""The PDF of a report is printed from its HTML by headless Chromium, so the file that is filed
shows what the HTML shows: the same tables, the figures in place, page breaks from CSS
(`@page`, `break-inside: avoid`), page numbers in the page margin and one PDF bookmark per
heading.

The browser is `$SNAPO_CHROMIUM` when set (an empty value means: none), else the first of
`chromium`, `chromium-browser`, `google-chrome`, `google-chrome-stable` on the PATH. Each print
runs in a fresh temporary profile, so concurrent reports do not share a browser profile lock.
"""

import os
import pathlib
import re
import shutil
import signal
import subprocess
import tempfile

from .._platform.validation import InputError

BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")
DEBIAN_PACKAGE = "chromium"
PRINT_TIMEOUT_SECONDS = 180


class PdfUnavailable(InputError):
    """No PDF could be printed: no headless Chromium, or it failed. A user can fix it (install the
    package), so the CLI reports it as an input error (exit 2) where a PDF is required."""


def find_chromium() -> str | None:
    """The Chromium binary, or None."""
    configured = os.environ.get("SNAPO_CHROMIUM")
    if configured is not None:
        return shutil.which(configured) if configured else None
    return next((found for name in BROWSERS if (found := shutil.which(name))), None)


def missing_message() -> str:
    return (f"headless Chromium was not found (looked for {', '.join(BROWSERS)} on the PATH, or $SNAPO_CHROMIUM); "
            f"install the Debian package `{DEBIAN_PACKAGE}` (apt-get install {DEBIAN_PACKAGE}) to print the PDF.")


def require_chromium() -> str:
    """The binary, or `PdfUnavailable` naming the package to install."""
    binary = find_chromium()
    if binary is None:
        raise PdfUnavailable(missing_message())
    return binary


def chromium_version() -> str | None:
    binary = find_chromium()
    if binary is None:
        return None
    try:
        out = subprocess.run([binary, "--version"], capture_output=True, text=True, timeout=60).stdout
    except (OSError, subprocess.SubprocessError):
        return None
    return out.strip().splitlines()[-1] if out.strip() else None


def print_pdf(html: str, *, timeout: float = PRINT_TIMEOUT_SECONDS) -> bytes:
    """`html` (a self-contained page) printed to PDF by headless Chromium, with its CSS for print.

    **Raises:** `PdfUnavailable` when Chromium is missing, fails or writes no PDF."""
    binary = require_chromium()
    with tempfile.TemporaryDirectory(prefix="snapo-pdf-") as tmp:
        tmp = pathlib.Path(tmp)
        page, target = tmp / "report.html", tmp / "report.pdf"
        page.write_text(html, encoding="utf-8")
        command = [binary, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
                   f"--user-data-dir={tmp / 'profile'}", "--no-pdf-header-footer",
                   "--generate-pdf-document-outline", f"--print-to-pdf={target}", page.as_uri()]
        # Chromium and its helpers in a session of their own, their temporary files inside `tmp`:
        # on a timeout or an interrupt (SIGINT, SIGTERM) all of them stop and nothing is left.
        try:
            process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                                       env={**os.environ, "TMPDIR": str(tmp)}, start_new_session=True)
        except OSError as error:
            raise PdfUnavailable(f"Chromium ({binary}) could not be run: {error}.") from None
        try:
            stderr = process.communicate(timeout=timeout)[1]
        except subprocess.TimeoutExpired:
            _stop(process)
            raise PdfUnavailable(f"Chromium ({binary}) did not print the PDF within {timeout:g} s.") from None
        except BaseException:
            _stop(process)
            raise
        if not target.is_file() or target.stat().st_size == 0:
            tail = " ".join((stderr or "").split()[-40:])
            raise PdfUnavailable(f"Chromium ({binary}) exited {process.returncode} without a PDF: {tail}")
        return target.read_bytes()


def _stop(process: subprocess.Popen) -> None:
    """Kill `process` and every process of its session, and wait for it."""
    try:
        os.killpg(process.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    process.communicate()


def count_pages(pdf: bytes) -> int:
    """The number of pages of a PDF (its page objects; Chromium writes them uncompressed)."""
    return len(re.findall(rb"/Type\s*/Page(?![s\w])", pdf))
