"""When to try a lost connection again: exponential backoff with a cap and jitter, reset by a stable connection.

The k-th wait after a loss (k = 0, 1, ...) is drawn from ``[step/2, step]`` with ``step = min(max_s,
initial_s * 2**k)``: "equal jitter" (M. Brooker, "Exponential Backoff And Jitter", AWS Architecture Blog,
2015). The random half spreads devices that failed together; the fixed half bounds the rate whatever the
device does: ``n`` attempts take at least ``sum(step_k / 2)`` seconds, so with the defaults (0.1 s doubling
to 5 s) a device that accepts and closes every connection at once gets at most 6 connections in the first
3 s and then one per 2.5 s at most. Full jitter (``[0, step]``) has no such floor.

The step goes back to ``initial_s`` only after a connection that stayed up for ``stable_s`` (default: the
cap, 5 s): a device that drops every connection at once keeps the step at the cap.
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field

#: first step after a loss, s: a serial adapter or a sonar back within 0.1 s is reopened at once
INITIAL_S = 0.1
#: the cap, s: a device that comes back is reopened within 5 s at most
MAX_S = 5.0


@dataclass
class Backoff:
    """The waits before reconnection attempts (see the module docstring)."""

    initial_s: float = INITIAL_S
    max_s: float = MAX_S
    stable_s: float | None = None  # a connection up this long resets the step (None: ``max_s``)
    rng: random.Random = field(default_factory=random.Random)
    attempts: int = 0  # waits drawn since the last reset

    def __post_init__(self) -> None:
        if not (self.initial_s > 0.0 and self.max_s > 0.0):
            raise ValueError(f"backoff needs initial_s > 0 and max_s > 0, got {self.initial_s}, {self.max_s}")
        self.initial_s = min(self.initial_s, self.max_s)

    @property
    def step_s(self) -> float:
        """The upper end of the next wait, s."""
        return min(self.max_s, self.initial_s * 2.0 ** min(self.attempts, 64))

    def next_wait(self) -> float:
        """The next wait, s, drawn from ``[step/2, step]``; the step doubles (up to the cap)."""
        step = self.step_s
        self.attempts += 1
        return step / 2.0 + self.rng.uniform(0.0, step / 2.0)

    def connection_lasted(self, up_s: float) -> None:
        """A connection that was up ``up_s`` seconds went: a stable one resets the step."""
        if up_s >= (self.max_s if self.stable_s is None else self.stable_s):
            self.attempts = 0

    @staticmethod
    def most_attempts(initial_s: float, max_s: float, seconds: float) -> int:
        """The most connection attempts within ``seconds`` from a first one at 0 (each wait at least step/2)."""
        n, spent, k = 1, 0.0, 0
        while True:
            spent += min(max_s, initial_s * 2.0 ** min(k, 64)) / 2.0
            if spent > seconds:
                return n
            n, k = n + 1, k + 1
