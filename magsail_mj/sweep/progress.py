"""The sweep-level progress bar: runs done / running / failed and the Dask dashboard, on stderr.

It counts the runs of one sweep call (not the runs reused from earlier calls): ``done`` is every
run that ended (whatever its status), ``failed`` those among them that did not succeed (failed,
diverged, interrupted, stopped, not_run), ``running`` the tasks the Dask scheduler is processing
now. It is on when asked (``enabled=True``), off with ``enabled=False`` (``--no-progress``), and
by default on only when the stream is a terminal.
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Any, TextIO

from tqdm import tqdm

from magsail_mj.sweep.common import _SUCCESS

__all__ = ["SweepProgress", "dashboard_address", "running_tasks"]


def dashboard_address(client: Any) -> str | None:
    """The Dask dashboard URL of ``client``'s scheduler, None when it serves none (no bokeh)."""
    try:
        services = client.scheduler_info().get("services", {})
    except (OSError, TimeoutError, AttributeError, RuntimeError):
        return None
    if "dashboard" not in services:
        return None
    try:
        return str(client.dashboard_link)
    except (KeyError, AttributeError, ValueError):
        return None


def running_tasks(client: Any, prefix: str, *, weight: Callable[[str], int] | None = None) -> int | None:
    """How many tasks whose key starts with ``prefix`` the scheduler's workers are processing now
    (None when the scheduler cannot be asked); with ``weight``, the sum of ``weight(key)`` over
    them (e.g. the runs of a batch task)."""
    try:
        processing = client.processing()
    except (OSError, TimeoutError, RuntimeError, AttributeError):
        return None
    keys = [str(key) for keys in processing.values() for key in keys if str(key).startswith(prefix)]
    return sum(weight(key) for key in keys) if weight is not None else len(keys)


class SweepProgress:
    """A tqdm bar over the ``total`` runs of one sweep call; ``enabled=None`` means "if a terminal"."""

    def __init__(self, *, total: int, enabled: bool | None = None, stream: TextIO | None = None) -> None:
        self.stream = stream if stream is not None else sys.stderr
        on = _is_terminal(self.stream) if enabled is None else bool(enabled)
        self.total = total
        self.failed = 0
        self.running = 0
        self.dashboard: str | None = None
        self._bar = (
            tqdm(
                total=total, file=self.stream, desc="sweep", unit="run", dynamic_ncols=True, leave=True, mininterval=0.5
            )
            if on and total > 0
            else None
        )
        self._show()

    @property
    def enabled(self) -> bool:
        """True when a bar is drawn."""
        return self._bar is not None

    def set_dashboard(self, address: str | None) -> None:
        """Show the dashboard ``address`` (``off`` when None)."""
        self.dashboard = address
        self._show()

    def set_running(self, running: int | None) -> None:
        """The number of runs being processed now (ignored when None: the scheduler did not answer)."""
        if running is not None and running != self.running:
            self.running = running
            self._show()

    def finished(self, status: str) -> None:
        """One run of this call ended with ``status``."""
        if status not in _SUCCESS:
            self.failed += 1
        self.running = max(0, self.running - 1)
        if self._bar is not None:
            self._bar.update(1)
        self._show()

    def write(self, line: str) -> None:
        """A message line that does not break the bar."""
        if self._bar is not None:
            self._bar.write(line, file=self.stream)

    def close(self) -> None:
        """Leave the final bar on its line."""
        if self._bar is not None:
            self._show()
            self._bar.close()
            self._bar = None

    def _show(self) -> None:
        if self._bar is not None:
            self._bar.set_postfix_str(
                f"running {self.running}, failed {self.failed}, dashboard {self.dashboard or 'off'}", refresh=True
            )


def _is_terminal(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False
