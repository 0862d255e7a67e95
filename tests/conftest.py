"""Shared fixtures: the real vendor captures in ../shared/data, the small mission simulated and replayed once
per session, and leak checks for threads, file descriptors and CAN buses."""

from __future__ import annotations

import contextlib
import json
import os
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from small_mission import SmallMissionRun, simulate_small

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    """The folder of real instrument captures; skips the test when it is absent."""
    if not SHARED_DATA.is_dir():
        pytest.skip(f"real captures not found at {SHARED_DATA} (clone with ../shared beside it)")
    return SHARED_DATA


@pytest.fixture(scope="session")
def small_mission_log(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The small mission simulated once per session. Read-only: a test that edits it works on a copy."""
    return simulate_small(tmp_path_factory.mktemp("small-mission") / "mission.mcap")


@pytest.fixture(scope="session")
def small_mission_run(small_mission_log: Path) -> SmallMissionRun:
    """The small mission replayed once per session (classified, with the report). Read-only, like the log."""
    from auvlink.cli import main

    out = small_mission_log.parent / "out"
    capture = small_mission_log.parent / "stdout.json"
    with open(capture, "w") as f, contextlib.redirect_stdout(f):
        assert main(["replay", str(small_mission_log), "--out", str(out), "--quiet", "--json"]) == 0
    return SmallMissionRun(small_mission_log, out, json.loads(capture.read_text()))  # one JSON object only


@pytest.fixture(autouse=True)
def no_leaked_threads() -> Iterator[None]:
    """Fail a test that leaves a non-daemon thread running (a port reader it forgot to stop)."""
    before = set(threading.enumerate())
    yield
    leaked = [
        t for t in threading.enumerate() if t not in before and t.is_alive() and not t.daemon
    ]
    for t in leaked:
        t.join(timeout=2.0)
    still = [t.name for t in leaked if t.is_alive()]
    assert not still, f"test leaked threads: {still}"


def _open_fds() -> dict[int, str]:
    fds: dict[int, str] = {}
    for entry in os.listdir("/proc/self/fd"):
        try:
            target = os.readlink(f"/proc/self/fd/{entry}")
        except OSError:  # the directory listing's own descriptor, closed by now
            continue
        fds[int(entry)] = target
    return fds


@pytest.fixture
def no_leaked_fds() -> Iterator[None]:
    """Opt-in: fail a test that leaves a file descriptor open (a pty, socket or port it forgot)."""
    if not os.path.isdir("/proc/self/fd"):
        yield
        return
    before = _open_fds()
    yield
    leaked = {fd: t for fd, t in _open_fds().items() if before.get(fd) != t}
    assert not leaked, f"test leaked file descriptors: {leaked}"


@pytest.fixture
def no_leaked_can_buses() -> Iterator[None]:
    """Opt-in: fail a test that leaves a python-can virtual bus open (it was never shut down)."""
    from can.interfaces import virtual

    before = {name: len(queues) for name, queues in virtual.channels.items()}
    yield
    after = {name: len(queues) for name, queues in virtual.channels.items()}
    leaked = {name: n - before.get(name, 0) for name, n in after.items() if n > before.get(name, 0)}
    assert not leaked, f"test leaked virtual CAN buses (channel: count): {leaked}"


#: the test files that take longest (``pytest --durations``, 2-core machine), started first in this order
HEAVIEST_FILES = ("test_bench_smoke.py", "test_classify_default.py", "test_classify_clutter.py",
                  "test_evaluation_clutter_sweep.py", "test_batch_resume.py", "test_log_tools.py",
                  "test_batch_e2e.py", "test_log_truncation.py", "test_batch_scheduler.py", "test_batch_trust.py")


@pytest.hookimpl(tryfirst=True)  # before xdist's own hook, which names each item's unit from these marks
def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Schedule for the xdist workers of ``make test`` (``--dist loadgroup``): a test file is one unit (its
    module fixtures are built once), except that a test marked ``train`` is a unit of its own (it trains and
    shares nothing worth keeping). Units start longest first: ``train`` tests, then :data:`HEAVIEST_FILES`,
    then the rest in file order, so that no long unit starts last. Without xdist (``-p no:xdist``) nothing."""
    if not config.pluginmanager.has_plugin("xdist"):
        return
    units: dict[str, list[pytest.Item]] = {}
    for item in items:
        marker = item.get_closest_marker("xdist_group")
        if marker is None:
            unit = item.nodeid if item.get_closest_marker("train") else item.nodeid.split("::")[0]
            item.add_marker(pytest.mark.xdist_group(unit))
        else:
            unit = str(marker.args[0] if marker.args else marker.kwargs.get("name", "default"))
        units.setdefault(unit, []).append(item)

    def rank(unit: list[pytest.Item]) -> tuple[int, int]:
        name = unit[0].path.name
        heavy = HEAVIEST_FILES.index(name) if name in HEAVIEST_FILES else len(HEAVIEST_FILES)
        return (0 if unit[0].get_closest_marker("train") else 1, heavy)

    items[:] = [i for unit in sorted(units.values(), key=rank) for i in unit]


UNGROUPED = pytest.StashKey[bool]()


@pytest.hookimpl(trylast=True)  # after xdist's own hook, which appends each item's group to its node id
def pytest_collection_finish(session: pytest.Session) -> None:
    """On an xdist worker of ``--dist loadgroup``: note when xdist could not name the items' groups (no node id
    carries ``@group``, as with pytest 9.2, whose node ids xdist 3.8 cannot extend): every test would go to any
    worker, and each worker build every module fixture of a file again (``make test`` minutes longer)."""
    config = session.config
    if hasattr(config, "workerinput") and getattr(config.option, "loadgroup", False) and session.items:
        config.stash[UNGROUPED] = not any("@" in item.nodeid for item in session.items)


def pytest_runtest_setup(item: pytest.Item) -> None:
    """Fail every test of a worker whose tests are not grouped (:func:`pytest_collection_finish`), saying why."""
    if item.config.stash.get(UNGROUPED, False):
        pytest.fail(f"pytest-xdist's --dist loadgroup found no test groups under pytest {pytest.__version__}: "
                    "keep pytest at the version pyproject.toml's dev extra pins", pytrace=False)
