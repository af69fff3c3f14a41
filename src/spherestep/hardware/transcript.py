"""The transcript of a run: every frame sent and received, with notes on retries and aborts."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

from ..atomic import write_text


@dataclass
class Transcript:
    """Time-stamped lines ``(seconds, kind, text)``; kinds ``TX``, ``RX``, ``NOTE``.

    Times are those of the back end's clock (monotonic seconds, or simulated seconds for a dry run), shown
    relative to the first entry. :meth:`write` saves it atomically, so a log file is whole or absent.
    """

    entries: list[tuple[float, str, str]] = field(default_factory=list)
    sink: TextIO | None = None  # a text file each line is also written (and flushed) to as it happens

    def add(self, t: float, kind: str, text: str) -> None:
        """Append one line; ``text`` is stripped of its line ending. With a ``sink`` the line is written and
        flushed at once, so a run that is killed still leaves its log."""
        self.entries.append((t, kind, text.rstrip("\r\n")))
        if self.sink is not None:
            self.sink.write(self._line(*self.entries[-1]) + "\n")
            self.sink.flush()

    def _line(self, t: float, kind: str, text: str) -> str:
        t0 = self.entries[0][0] if self.entries else 0.0
        return f"{t - t0:11.6f} {kind:<4} {text}"

    def count(self, kind: str, prefix: str = "") -> int:
        """How many entries of ``kind`` have text starting with ``prefix``."""
        return sum(1 for _, k, text in self.entries if k == kind and text.startswith(prefix))

    def lines(self) -> list[str]:
        """``"   0.012345 TX   $01,SET,3,0*1A2B"``: seconds since the first entry, kind, text."""
        return [self._line(*entry) for entry in self.entries]

    def write(self, path: str | Path) -> Path:
        """Write :meth:`lines` to ``path`` (atomically, UTF-8, one entry per line)."""
        return write_text(path, "".join(line + "\n" for line in self.lines()))
