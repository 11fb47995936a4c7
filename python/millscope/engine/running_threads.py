"""How many threads run the engine's shares of a step, chosen by timing the engine's calls.

The engine splits each step into ``threads`` shares and sums their parts in share order, so its
results depend on ``threads`` alone. The shares may be run by ``threads`` threads, one each,
or by one thread running them in turn, with the same results to the bit
(``_core.Engine.running_threads``). On an idle machine the full team is usually the faster;
when other programs hold some of the cores, a thread that the system has put aside leaves
the others waiting at the step's barriers, and the team can step several times slower than one
thread alone. :class:`RunningThreads` keeps whichever of the two settings steps faster now.
"""

from __future__ import annotations

import math
import statistics
from collections import deque

__all__ = ["RunningThreads"]


class RunningThreads:
    """Chooses, call by call, whether the engine's shares run on all its threads or on one.

    It starts on one thread (a wrong start then costs a fraction of ``first_wait_s``, where
    the team on a busy machine could take several times longer for its first call), in calls
    as short as probes until the first probe has been decided, and runs the current setting,
    with now and then a short call of the other setting (a probe, of about ``probe_s`` s at
    the current rate). Two probes in a row faster than the median of
    the current setting's recent calls by more than ``margin`` make the other setting the
    current one (one lucky probe does not). A probe that loses doubles the wait before the
    next, up to ``max_wait_s``, and the wait is at least ``probe_share`` times the probe's own
    wall time, so that losing probes take at most about 1 / ``probe_share`` of the run. A
    call whose rate moves by more than ``drop`` from that median (the machine got busier, or
    freer) brings the next probe forward.

    Parameters
    ----------
    threads : int
        The engine's threads (its shares), >= 1. With one there is nothing to choose.
    first_wait_s : float
        Wall time, s, of calls at the current setting before the first probe, and after a
        switch; > 0.
    max_wait_s : float
        Longest wait between probes, s; >= ``first_wait_s``.
    probe_s : float
        Wall time a probe would take at the current setting's rate, s; > 0.
    margin : float
        Relative speed-up a probe needs to win, >= 0.
    drop : float
        Relative change of a call's rate that brings a probe forward, in (0, 1).
    recent : int
        Calls of the current setting whose rates make the median, >= 1.
    probe_share : float
        The least wait after a lost probe, in units of the probe's wall time, >= 1.
    """

    #: the fewest steps of a probe, and the steps of the first call
    MIN_PROBE_STEPS = 20

    def __init__(self, threads: int, *, first_wait_s: float = 0.1, max_wait_s: float = 256.0,
                 probe_s: float = 0.05, margin: float = 0.05, drop: float = 0.3,
                 recent: int = 5, probe_share: float = 20.0) -> None:
        if isinstance(threads, bool) or not isinstance(threads, int) or threads < 1:
            raise ValueError(f"threads = {threads!r} is not valid; it must be an integer >= 1")
        for name, value in (("first_wait_s", first_wait_s), ("probe_s", probe_s)):
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError(f"{name} = {value!r} s is not valid; it must be > 0")
        if not (math.isfinite(max_wait_s) and max_wait_s >= first_wait_s):
            raise ValueError(f"max_wait_s = {max_wait_s!r} s is not valid; it must be >= "
                             f"first_wait_s = {first_wait_s} s")
        if not (math.isfinite(margin) and margin >= 0.0):
            raise ValueError(f"margin = {margin!r} is not valid; it must be >= 0")
        if not (math.isfinite(drop) and 0.0 < drop < 1.0):
            raise ValueError(f"drop = {drop!r} is not valid; it must be in (0, 1)")
        if isinstance(recent, bool) or not isinstance(recent, int) or recent < 1:
            raise ValueError(f"recent = {recent!r} is not valid; it must be an integer >= 1")
        if not (math.isfinite(probe_share) and probe_share >= 1.0):
            raise ValueError(f"probe_share = {probe_share!r} is not valid; it must be >= 1")
        self.threads = threads
        self._first_wait_s = first_wait_s
        self._max_wait_s = max_wait_s
        self._probe_s = probe_s
        self._margin = margin
        self._drop = drop
        self._probe_share = probe_share
        self.current = 1  #: the setting that runs between probes
        self._rates: deque[float] = deque(maxlen=recent)  # steps/s of the current setting
        self._wait_s = first_wait_s
        self._since_probe_s = 0.0
        self._probe_due = False
        self._won = False  # the last probe won; the next one decides
        self.probes = 0  #: probes run so far
        self.switches = 0  #: times the current setting changed

    @property
    def other(self) -> int:
        """The setting a probe tries."""
        return 1 if self.current == self.threads else self.threads

    def plan(self, max_steps: int) -> tuple[int, int]:
        """The running threads and the most steps for the next call, which may take up to
        ``max_steps`` (>= 1) steps."""
        if self.threads == 1:
            return self.current, max_steps
        if not self._rates:
            return self.current, min(max_steps, self.MIN_PROBE_STEPS)
        probe_steps = max(1, min(max_steps, max(self.MIN_PROBE_STEPS,
                                                int(self._median() * self._probe_s))))
        if self._probe_due or self._won or self._since_probe_s >= self._wait_s:
            return self.other, probe_steps
        if self.probes == 0:  # nothing decided yet: no long call on a setting that may be slow
            return self.current, probe_steps
        return self.current, max_steps

    def record(self, running: int, steps: int, wall_s: float) -> None:
        """Books a call: ``steps`` steps taken by ``running`` threads in ``wall_s`` s."""
        if self.threads == 1 or steps <= 0 or not wall_s > 0.0:
            return
        if running not in (self.current, self.other) or (running != self.current
                                                          and not self._rates):
            return  # not a setting this chose
        rate = steps / wall_s
        if running == self.current:
            if len(self._rates) >= 2 and abs(rate - self._median()) > self._drop * self._median():
                self._rates.clear()  # a new regime: the probe is measured against it
                self._probe_due = True
            self._rates.append(rate)
            self._since_probe_s += wall_s
            return
        self.probes += 1
        self._probe_due = False
        self._since_probe_s = 0.0
        if rate <= (1.0 + self._margin) * self._median():
            self._won = False
            self._wait_s = max(min(2.0 * self._wait_s, self._max_wait_s),
                               self._probe_share * wall_s)
        elif not self._won:
            self._won = True  # once more before switching
        else:
            self._won = False
            self.current = running
            self.switches += 1
            self._rates.clear()
            self._rates.append(rate)
            self._wait_s = self._first_wait_s

    def _median(self) -> float:
        return statistics.median(self._rates)
