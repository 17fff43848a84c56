"""Progress of a benchmark while it runs: one tqdm bar on stderr, the figures on stdout.

Not a benchmark itself (the leading underscore): the scripts beside it import it (``python
benchmarks/NAME.py`` puts this directory first on ``sys.path``).

The bar counts what the benchmark has done of what it will do: commands sent, LAND trials, flight
phases (stack up, take-off, hover, each corner, landing ...) of every flight, landings of a campaign.
Its label says which run is going on, and its postfix what that run is doing now and the simulated
seconds its flight controller has flown (``watch`` a client; the postfix follows its clock from the
client's ``idle`` hook, called on every receive cycle).  Lines the benchmark prints go through
:meth:`Progress.say`, to stdout, so they do not tear the bar; redirect stderr to drop the bar.
"""

from __future__ import annotations

import sys
import time
from typing import Any, Callable

from tqdm import tqdm

# Wall seconds between two redraws: often on a terminal, seldom into a file (each redraw is another line).
REDRAW_S = 0.5 if sys.stderr.isatty() else 10.0


class Progress:
    """A benchmark's one progress bar: ``total`` things of ``unit`` (None: no known total)."""

    def __init__(self, total: int | None, unit: str, desc: str = "") -> None:
        self.bar = tqdm(
            total=total,
            unit=unit,
            desc=desc,
            file=sys.stderr,
            dynamic_ncols=True,
            mininterval=REDRAW_S,
            smoothing=0.05,
        )
        self._drawn = time.monotonic()
        self._phase = ""
        self._client: Any = None
        self._extra = ""

    def __enter__(self) -> "Progress":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Leave the bar on screen where it stopped (again: nothing)."""
        if not self.bar.disable:
            self._refresh()
            self.bar.close()

    def label(self, text: str) -> None:
        """Which run is going on (the bar's left-hand text)."""
        self.bar.set_description_str(text, refresh=False)
        self.bar.refresh()

    def phase(self, text: str) -> None:
        """What the current run is doing now (start of the postfix)."""
        self._phase = text
        self._refresh()

    def note(self, text: str) -> None:
        """A figure to keep showing after the phase (acknowledged commands, failures ...)."""
        self._extra = text
        self._refresh()

    def done(self, n: int = 1, phase: str | None = None) -> None:
        """``n`` more things done; then, if given, the next phase."""
        if phase is not None:
            self._phase = phase
            self._refresh(redraw=False)
        self.bar.update(n)

    def finish(self, phase: str) -> None:
        """All done (what was not counted on the way too, e.g. a mission item never reported current)."""
        self.done(self.bar.total - self.bar.n, phase)

    def watch(self, client: Any) -> None:
        """Show this client's simulated clock (``sim_time_s()``, seconds since its stack started); None: stop."""
        self._client = client

    def idle(self, check: Callable[[], object] | None = None) -> Callable[[], None]:
        """A ``VehicleClient`` idle hook: ``check()`` (e.g. ``stack.check_alive``), then refresh the postfix."""

        def hook() -> None:
            if check is not None:
                check()
            now = time.monotonic()
            if now - self._drawn >= REDRAW_S:
                self._drawn = now
                self._refresh()

        return hook

    def say(self, text: str) -> None:
        """Print a line on stdout, above the bar."""
        tqdm.write(text, file=sys.stdout)
        sys.stdout.flush()

    def _refresh(self, redraw: bool = True) -> None:
        parts = [p for p in (self._phase, self._extra) if p]
        sim_s = self._client.sim_time_s() if self._client is not None else None
        if sim_s is not None:
            parts.append(f"sim {sim_s:.0f} s")
        self.bar.set_postfix_str(", ".join(parts), refresh=redraw)
