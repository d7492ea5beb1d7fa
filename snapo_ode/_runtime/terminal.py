"""What a `snapo` command prints reaches any terminal safely, in any locale.

Within `safe_streams()` (the command line's whole run), `sys.stdout` and `sys.stderr` escape, in
everything written to them:

- control characters other than newline, tab and carriage return (an escape sequence in a file's
  key or a path, a bell, a C1 control): written as Python writes them in a `repr`, `\\x1b`, so a
  user's file cannot recolour, retitle or clear the terminal;
- characters the stream's encoding cannot show (`LANG=C`, `PYTHONIOENCODING=ascii`): as
  `\\xe9`, `\\u2009` (`backslashreplace`), so a line about a result already written never fails
  with `UnicodeEncodeError`.
"""

import contextlib
import io
import re
import sys
from collections.abc import Iterator
from typing import TextIO

# C0 controls but \t \n \r, DEL and the C1 controls (\x9b is a one-byte CSI on some terminals).
_CONTROL = re.compile(r"[\x00-\x08\x0b\x0c\x0e-\x1f\x7f-\x9f]")


def printable(text: str, encoding: str | None = None) -> str:
    """`text` with its control characters (but newline, tab, carriage return) escaped as in a
    `repr`, and with `encoding`, the characters it cannot encode as well (`backslashreplace`)."""
    text = _CONTROL.sub(lambda match: repr(match.group())[1:-1], text)
    if encoding:
        try:
            text.encode(encoding)
        except UnicodeEncodeError:
            text = text.encode(encoding, "backslashreplace").decode(encoding)
        except LookupError:
            pass
    return text


class _Escaping(io.TextIOBase):
    """A text stream writing `printable` text into `stream`; everything else is the stream's."""

    def __init__(self, stream: TextIO):
        self._stream = stream

    def write(self, text: str) -> int:
        self._stream.write(printable(text, getattr(self._stream, "encoding", None)))
        return len(text)

    def flush(self) -> None:
        self._stream.flush()

    def isatty(self) -> bool:
        return self._stream.isatty()

    def fileno(self) -> int:
        return self._stream.fileno()

    def writable(self) -> bool:
        return True

    @property
    def encoding(self):
        return getattr(self._stream, "encoding", None)

    def __getattr__(self, name):
        return getattr(self._stream, name)


@contextlib.contextmanager
def safe_streams() -> Iterator[None]:
    """Within it, `sys.stdout` and `sys.stderr` write `printable` text (see the module)."""
    saved = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = (_Escaping(stream) if stream is not None else None for stream in saved)
    try:
        yield
    finally:
        for stream in (sys.stdout, sys.stderr):
            if stream is not None:
                with contextlib.suppress(OSError, ValueError):
                    stream.flush()
        sys.stdout, sys.stderr = saved
