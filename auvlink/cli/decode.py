"""``auvlink decode FILE --format FMT [--jsonl]``: any supported wire or file format -> records.

A damaged file decodes every good frame and reports the bad ones on stderr. The exit code is
non-zero only when nothing could be decoded, with a one-line reason.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from auvlink import formats
from auvlink.decode_file import decode_path
from auvlink.errors import AuvlinkError
from auvlink.jsonutil import dumps


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("file", type=Path, help="the file to decode (a raw capture of the wire format)")
    p.add_argument("--format", "-f", required=True, choices=formats.names(), help="wire format of FILE")
    p.add_argument("--jsonl", action="store_true", help="one JSON object per record on stdout")
    p.add_argument(
        "--json", action="store_true", help="the summary as one JSON object, with the first and last records' fields"
    )


def run(args: argparse.Namespace) -> int:
    if not args.file.is_file():  # a folder, or a FIFO or device that would block or never end
        why = "not a regular file (a folder, FIFO or device)" if args.file.exists() else "no such file"
        raise AuvlinkError(f"{args.file}: {why}; give a capture file")
    fmt = formats.get(args.format)
    out = sys.stdout
    n_records = 0
    first: object = None  # the first and the last record, for --json
    last: object = None

    def emit(record: object) -> None:
        nonlocal n_records, first, last
        n_records += 1
        if n_records == 1:
            first = record
        last = record
        if args.jsonl:
            out.write(dumps(_as_json(fmt, record)) + "\n")

    result = decode_path(args.file, fmt, emit)
    for problem in result.problems[:50]:
        print(f"auvlink decode: {args.file.name}: {problem}", file=sys.stderr)
    more = len(result.problems) + result.problems_left_out - 50
    if more > 0:
        print(f"auvlink decode: ... and {more} more problems", file=sys.stderr)
    if args.json:
        summary = result.summary()
        if n_records:
            summary["first_record"] = _as_json(fmt, first)
            summary["last_record"] = _as_json(fmt, last)
        out.write(dumps(summary) + "\n")
    elif not args.jsonl:
        out.write(result.human_summary() + "\n")
    if n_records == 0:
        print(
            f"auvlink: error: {args.file}: no {fmt.name} record could be decoded ({result.reason()})",
            file=sys.stderr,
        )
        return 2
    return 0


def _as_json(fmt: formats.WireFormat, record: object) -> object:
    """A record as the format writes it to JSON (its own ``to_json`` where it has one)."""
    return fmt.to_json(record) if fmt.to_json else record
