"""How a run goes bad, detected the same way by every runner.

MuJoCo checks each step for positions or velocities that are not finite or exceed ``1e10``
(``mjWARN_BADQPOS``, ``mjWARN_BADQVEL``), accelerations that are not finite or huge
(``mjWARN_BADQACC``) and controls that are not finite or exceed ``1e10`` (``mjWARN_BADCTRL``, after
which it zeroes them), and a step whose constraints or contacts do not fit the arena
(``mjWARN_CNSTRFULL``, ``mjWARN_CONTACTFULL``: MuJoCo drops them from that step and goes on, so
a welded beam loop would silently come apart). By default it then *resets* ``mjData`` to the model's initial state and
carries on, which a step loop cannot tell from a quiet spacecraft. Every runner of this package
therefore

* switches that automatic reset off (:func:`disable_autoreset`), so a bad state stays bad and
  visible, and
* reads MuJoCo's warning counters after every step (:class:`WarningWatch`) together with a
  finiteness check of ``qpos`` and ``qvel``; either raises :class:`DivergenceError` naming the
  simulated time of the first bad state and the cause.

A strut strain above the configured bound (``sim.max_strain``) is a *structural failure*
(:class:`StructureFailure`), and a scenario may end on another condition it studies (a
:class:`StudiedFailure`, e.g. :class:`TrackingLost`): the numbers up to it are valid and the run
reports that status; it is not a numerical divergence.

MuJoCo's warning texts are routed to Python's :mod:`logging` (logger ``magsail_mj.mujoco``)
instead of MuJoCo's default, which also appends them to ``MUJOCO_LOG.TXT`` in the current folder.
"""

from __future__ import annotations

import logging

import mujoco
import numpy as np

__all__ = [
    "DivergenceError",
    "StudiedFailure",
    "check_inner_run",
    "StructureFailure",
    "TrackingLost",
    "WarningWatch",
    "disable_autoreset",
    "first_bad_row",
    "route_mujoco_warnings",
]

_MAX_VALUE = 1e10  # MuJoCo's mjMAXVAL: its bound on |qpos|, |qvel|, |qacc| and |ctrl|

_LOG = logging.getLogger("magsail_mj.mujoco")

#: MuJoCo warnings that mean the state or the controls went bad.
BAD_STATE_WARNINGS = {
    mujoco.mjtWarning.mjWARN_BADQPOS: "a position is not finite or above 1e10",
    mujoco.mjtWarning.mjWARN_BADQVEL: "a velocity is not finite or above 1e10",
    mujoco.mjtWarning.mjWARN_BADQACC: "an acceleration is not finite or huge (unstable step)",
    mujoco.mjtWarning.mjWARN_BADCTRL: "a control is not finite or above 1e10",
    mujoco.mjtWarning.mjWARN_CNSTRFULL: "the arena is too small for the constraints: they were dropped from the step",
    mujoco.mjtWarning.mjWARN_CONTACTFULL: "the arena is too small for the contacts: they were dropped from the step",
}


class DivergenceError(RuntimeError):
    """The simulated state went bad (not finite, or flagged by MuJoCo); message: time and cause.

    ``t_s`` is the simulated time of the first bad state when known (records from it on are not
    valid numbers)."""

    def __init__(self, message: str, t_s: float | None = None):
        super().__init__(message)
        self.t_s = t_s


class StudiedFailure(RuntimeError):
    """A failure a scenario is built to find (its numbers up to then are valid); the run ends
    with status :attr:`status`."""

    status = "failed_condition"


class StructureFailure(StudiedFailure):
    """A strut exceeded the configured strain bound: the structure failed (not a divergence)."""

    status = "structure_failed"


class TrackingLost(StudiedFailure):
    """A tracking error passed the scenario's watchdog limit (the reflector capability search)."""

    status = "tracking_lost"


def check_inner_run(status: str, message: str, *, where: str) -> None:
    """For runners made of inner runs (a sweep inside a scenario): an inner run that diverged
    raises :class:`DivergenceError` naming ``where``; one that was interrupted re-raises the
    interrupt. Completed runs and studied failures pass."""
    if status == "interrupted":
        raise KeyboardInterrupt(f"{where}: {message}")
    if status == "diverged":
        raise DivergenceError(f"{where}: {message}")


def first_bad_row(states: np.ndarray) -> int | None:
    """Index of the first row of ``states`` (n, k) holding a value that is not finite or above
    MuJoCo's 1e10 bound, or ``None``."""
    states = np.asarray(states)
    if states.size == 0:
        return None
    bad = ~(np.abs(states.reshape(len(states), -1)) <= _MAX_VALUE).all(axis=1)
    return int(np.argmax(bad)) if bad.any() else None


def _log_warning(text: str) -> None:
    _LOG.warning("MuJoCo: %s", text)


def route_mujoco_warnings() -> None:
    """Send MuJoCo's warning texts to :mod:`logging` (no ``MUJOCO_LOG.TXT`` in the current folder)."""
    if mujoco.get_mju_user_warning() is not _log_warning:
        mujoco.set_mju_user_warning(_log_warning)


def disable_autoreset(model: mujoco.MjModel) -> None:
    """Switch off MuJoCo's reset of ``mjData`` on a bad state (see module docs)."""
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_AUTORESET)


class WarningWatch:
    """MuJoCo's bad-state warning counters of one ``mjData``, compared with their values at start."""

    def __init__(self, data: mujoco.MjData):
        self.data = data
        self._stats = [data.warning[int(w)] for w in BAD_STATE_WARNINGS]
        self._start = [s.number for s in self._stats]

    def raised(self) -> list[str]:
        """Names of the bad-state warnings raised since this watch began."""
        return [
            w.name.removeprefix("mjWARN_")
            for w, s, n0 in zip(BAD_STATE_WARNINGS, self._stats, self._start)
            if s.number > n0
        ]

    def check(self, t_s: float) -> None:
        """Raise :class:`DivergenceError` if a bad-state warning was raised; ``t_s`` is the time of
        the state MuJoCo checked (the start of the step it was raised in)."""
        for w, s, n0 in zip(BAD_STATE_WARNINGS, self._stats, self._start):
            if s.number > n0:
                raise DivergenceError(
                    f"MuJoCo {w.name.removeprefix('mjWARN_')} at t = {t_s:.6g} s: {BAD_STATE_WARNINGS[w]}", t_s
                )
