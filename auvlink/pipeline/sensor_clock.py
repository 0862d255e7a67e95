"""A sonar frame's time on the host clock, from the sonar's own clock: frames that arrive together are not
taken at one instant.

A frame is stamped when the host receives it. A network sonar's frames wait in the sonar's and the host's buffers,
and a stalled link delivers a burst of frames at once: stamped by arrival, the burst's frames would all be placed at
one pose. Each frame also carries the sonar's own time of the ping (a DIDSON's or an ARIS's ``FrameTime``, an
Oculus' ping start time since power-up), spaced as the pings were, on a clock with its own origin.

:class:`SensorClock` maps a device's sensor time ``s`` to the host clock as ``s + offset``, where the offset is the
least ``receive - s`` of the frames of the last :data:`WINDOW_S` s of sensor time: the transport only ever adds
delay, so the least delay seen is the link's own and a frame of a burst keeps its ping's spacing. The mapped time
never exceeds the frame's receive time (its own delay is in the window) and never goes back (a frame is never timed
before the one before it); a frame that came within :data:`TOLERANCE_S` of that keeps its receive time as it is.
When the sensor clock jumps against the host's by more than :data:`JUMP_S` (a sonar
restarted, its clock set) the window starts afresh. A frame without a sensor time keeps its receive time.
"""

from __future__ import annotations

import math
from collections import deque

#: s of sensor time whose frames' least delay gives the offset: long enough to hold frames that came without
#: waiting (a stall of a few seconds leaves most of the window prompt), short enough that the drift of a sonar's
#: clock against the host's (crystal oscillators, tens of ppm: under 2 ms over 30 s) stays below a ping interval
WINDOW_S = 30.0
#: s: a change of ``receive - sensor`` beyond this is a jump of one of the clocks, not transport delay (a link that
#: stalls this long has lost the frames between anyway)
JUMP_S = 10.0
#: s: a frame mapped this close to its receipt keeps its receive time (1.5 m/s, the fastest survey speed, moves the
#: sonar 3 mm in it; a log replays with the times it was recorded with, not their float64 sensor-time rounding)
TOLERANCE_S = 0.002


class SensorClock:
    """Maps one device's sensor times (s, any origin) to host times (ns since the epoch); module docstring."""

    def __init__(self) -> None:
        self._window: deque[tuple[float, int]] = deque()  # (sensor s, receive - sensor ns), increasing delay
        self._last_sensor = -math.inf
        self._last_out = -(2**62)
        #: window restarts on a clock jump
        self.resets = 0

    def host_ns(self, receive_ns: int, sensor_s: float | None) -> int:
        """The host time (ns) of a frame received at ``receive_ns`` whose sensor time is ``sensor_s`` (None or not
        finite: none; the receive time)."""
        if sensor_s is None or not math.isfinite(sensor_s):
            out = receive_ns
        else:
            delay = receive_ns - round(sensor_s * 1e9)
            if self._window and (sensor_s < self._last_sensor
                                 or abs(delay - self._window[0][1]) > JUMP_S * 1e9):
                self._window.clear()
                self.resets += 1
            self._last_sensor = sensor_s
            while self._window and self._window[-1][1] >= delay:  # a monotone deque: the front is the least delay
                self._window.pop()
            self._window.append((sensor_s, delay))
            while self._window[0][0] < sensor_s - WINDOW_S:
                self._window.popleft()
            out = round(sensor_s * 1e9) + self._window[0][1]
            if receive_ns - out <= TOLERANCE_S * 1e9:
                out = receive_ns
        out = max(out, self._last_out)
        self._last_out = out
        return out
