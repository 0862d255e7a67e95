"""The ``auvlink`` command line: one entry point, one module per subcommand (imported when used).

Each subcommand module defines ``add_arguments(parser)`` and ``run(args) -> int``.
Errors from the package print one line on stderr (``auvlink: error: ...``) and exit 1; never a
traceback unless ``AUVLINK_DEBUG=1`` (exit 2 for an output that would replace an input:
:class:`~auvlink.errors.InputOverwriteError`). So does an ``OSError`` that reaches here (a full disk, a path
that cannot be written): one line naming the file and the reason. Usage errors exit 2 (argparse).
"""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import os
import sys
from collections.abc import Sequence

from auvlink.errors import AuvlinkError
from auvlink.version import __version__

#: subcommand -> (module, one-line help)
COMMANDS: dict[str, tuple[str, str]] = {
    "decode": ("auvlink.cli.decode", "decode a wire-format file into records (summary or JSON lines)"),
    "bench": ("auvlink.cli.bench", "run benchmarks (run time against error, peers in the same run)"),
    "record": ("auvlink.cli.record", "record the ports of a config file into an MCAP mission log"),
    "log": ("auvlink.cli.log", "inspect, export and import mission logs"),
    "replay": ("auvlink.cli.replay", "replay a mission log through the live pipeline"),
    "batch": ("auvlink.cli.batch", "replay many mission logs on a Dask cluster and build the site catalogue"),
    "sim": ("auvlink.cli.sim", "simulate a mission into a log or live on virtual ports"),
    "live": ("auvlink.cli.live", "run the onboard pipeline on the ports of a config file"),
    "train": ("auvlink.cli.train", "train the PointNet classifier on synthesized clouds"),
    "eval": ("auvlink.cli.evaluate", "evaluate a classifier checkpoint"),
    "demo": ("auvlink.cli.demo", "simulate, replay, reconstruct, classify and write a report"),
}


def _available() -> dict[str, tuple[str, str]]:
    out = {}
    for name, (module, help_text) in COMMANDS.items():
        if importlib.util.find_spec(module) is not None:
            out[name] = (module, help_text)
    return out


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="auvlink",
        description="AUV sensor drivers, mission logs, simulation, 3D sonar reconstruction, classification.",
    )
    parser.add_argument("--version", action="version", version=f"auvlink {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    for name, (module_name, help_text) in _available().items():
        module = importlib.import_module(module_name)
        p = sub.add_parser(name, help=help_text, description=help_text)
        module.add_arguments(p)
        p.set_defaults(_run=module.run)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        code: int = args._run(args)
    except AuvlinkError as exc:
        if os.environ.get("AUVLINK_DEBUG"):
            raise
        print(f"auvlink: error: {exc}", file=sys.stderr)
        return int(getattr(exc, "exit_status", 1))  # 2: an output that would replace an input
    except KeyboardInterrupt:
        return 130
    except BrokenPipeError:  # e.g. `auvlink decode ... --jsonl | head`: the reader left; not an error
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except OSError as exc:  # disk full, a folder gone: outputs are written atomically, so nothing is half
        if os.environ.get("AUVLINK_DEBUG"):
            raise
        where = f" {exc.filename}" if exc.filename else ""
        print(f"auvlink: error: cannot write or read{where}: {exc.strerror or exc}", file=sys.stderr)
        return 1
    return code


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
