"""auvlink.clock.process_age_s: this process's age (for the start-up to the first frame, summary first_frame_s)."""

from __future__ import annotations

import subprocess
import sys
import time

from auvlink.clock import process_age_s


def test_age_grows_with_the_process() -> None:
    a = process_age_s()
    if a is None:  # no /proc: not Linux
        return
    time.sleep(0.05)
    b = process_age_s()
    assert b is not None and 0.0 < a < b


def test_a_fresh_process_is_young() -> None:
    code = "from auvlink.clock import process_age_s; a = process_age_s(); print(-1 if a is None else a)"
    age = float(subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout)
    assert age == -1 or 0.0 < age < 30.0  # interpreter start and one import, on a loaded machine
