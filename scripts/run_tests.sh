#!/usr/bin/env bash
# `make test`'s suite on a 2-core machine: three jobs side by side, each report printed when all are done.
# - the real-time tests (`live`) in one process at normal priority: they mostly wait on real clocks, and the
#   kernel gives them the CPU first when they need it, so their latencies are not those of a loaded machine;
# - every other test on both cores (pytest-xdist, conftest.py's schedule) and mypy, both at nice 10: they take
#   what the live tests leave.
# The suite's 15 slowest tests are listed after it (the place to look when it grows).
# Exit status: non-zero when any of the three failed.
set -u
BIN=${BIN:-.venv/bin}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

"$BIN/python" -m pytest -m live > "$work/live.log" 2>&1 &
live_pid=$!
nice -n 10 "$BIN/mypy" > "$work/mypy.log" 2>&1 &
mypy_pid=$!
echo "live tests and mypy running beside the suite; their reports follow it"
nice -n 10 "$BIN/python" -m pytest -n 2 --dist loadgroup --no-loadscope-reorder -m "not live" --durations=15
suite=$?
wait "$live_pid"; live=$?
wait "$mypy_pid"; typed=$?
echo "== $BIN/python -m pytest -m live"; cat "$work/live.log"
echo "== $BIN/mypy"; cat "$work/mypy.log"
test "$suite" -eq 0 -a "$live" -eq 0 -a "$typed" -eq 0
