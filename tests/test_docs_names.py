"""Every dotted Python name the documentation puts in backticks resolves in the code as it is.

Checked files: README.md, CONTRIBUTING.md and every ``docs/*.md``. In each inline code span (fenced blocks
are code, not names) a dotted name is checked when it is

* ``package.module[.attr...]`` rooted in one of the project's packages (``auvlink``, ``logs_format``,
  ``recon``, ``classify``): the longest prefix that imports is the module, the rest are attributes;
* ``Class.attr[...]`` (capitalised first part): the class is looked up by a search over the packages'
  sources for ``class Class``, its module imported and the attribute taken from the class (an instance
  attribute counts when the class annotates it or assigns ``self.attr``).

File names (``summary.json``, ``docs/ARCHITECTURE.md``) and other libraries' lowercase names
(``os.cpu_count``) are not names of this project and are skipped. A renamed or removed class, function,
method or module makes the test fail, listing every name that no longer resolves with its file and line.
"""

from __future__ import annotations

import functools
import importlib
import inspect
import re
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("auvlink", "logs_format", "recon", "classify")
DOCS = sorted([ROOT / "README.md", ROOT / "CONTRIBUTING.md", *(ROOT / "docs").glob("*.md")])
#: last parts that make a dotted word a file name, not a Python name
FILE_SUFFIXES = frozenset({"md", "py", "json", "jsonl", "toml", "mcap", "partial", "ply", "html", "csv", "png",
                           "pt", "geojson", "kml", "txt", "bin", "nmea", "pd0", "pd6", "sh", "000", "yaml", "dbc",
                           "npy", "npz", "stl", "obj", "gz"})
#: dotted names in the docs that are not Python names: MCAP schema names of the mission log (logs_format.profile)
NOT_PYTHON = frozenset({"auvlink.Event"})

FENCE = re.compile(r"^```.*?^```", re.S | re.M)
SPAN = re.compile(r"`([^`\n]+)`")
DOTTED = re.compile(r"(?<![\w./-])([A-Za-z_]\w*(?:\.[A-Za-z_]\w*)+)(?![\w/])")


@dataclass(frozen=True)
class DocName:
    """A dotted name as the documentation writes it, and where."""

    name: str
    file: str
    line: int


def doc_names(text: str, file: str) -> list[DocName]:
    """The dotted names to check in ``text`` (Markdown), with their line numbers."""
    text = FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), text)  # keep line numbers
    found = []
    for span in SPAN.finditer(text):
        line = text.count("\n", 0, span.start()) + 1
        for m in DOTTED.finditer(span.group(1)):
            name = m.group(1)
            parts = name.split(".")
            if any(p in FILE_SUFFIXES for p in parts[1:]) or name in NOT_PYTHON:
                continue
            if parts[0] in PACKAGES or parts[0][0].isupper():
                found.append(DocName(name, file, line))
    return found


@functools.cache
def class_modules() -> dict[str, tuple[str, ...]]:
    """Class name -> the modules of the project's packages that define a top-level class of that name."""
    out: dict[str, list[str]] = {}
    for pkg in PACKAGES:
        for path in sorted((ROOT / pkg).rglob("*.py")):
            module = ".".join(path.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")
            for m in re.finditer(r"^class (\w+)\b", path.read_text(encoding="utf-8"), re.M):
                out.setdefault(m.group(1), []).append(module)
    return {k: tuple(v) for k, v in out.items()}


def _has_attr(obj: object, attr: str) -> bool:
    if hasattr(obj, attr):
        return True
    if inspect.isclass(obj):  # an instance attribute: annotated on the class, or assigned in its methods
        for klass in obj.__mro__:
            if attr in getattr(klass, "__annotations__", {}):
                return True
            try:
                source = inspect.getsource(klass)
            except (OSError, TypeError):
                continue
            if re.search(rf"\bself\.{re.escape(attr)}\s*(?::[^=\n]+)?=", source):
                return True
    return False


def _walk(obj: object, attrs: list[str], where: str) -> str | None:
    for attr in attrs:
        if not _has_attr(obj, attr):
            return f"{where} has no attribute {attr!r}"
        where = f"{where}.{attr}"
        obj = getattr(obj, attr, None)
        if obj is None:  # an instance attribute: nothing further to walk
            return None
    return None


def _import(name: str) -> ModuleType | None:
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as exc:
        if exc.name is not None and name.startswith(exc.name):
            return None  # the module itself (or a package above it) does not exist
        raise


def resolve(name: str) -> str | None:
    """None when ``name`` resolves; otherwise why not, in one line."""
    parts = name.split(".")
    if parts[0] in PACKAGES:
        for k in range(len(parts), 0, -1):
            module = _import(".".join(parts[:k]))
            if module is not None:
                return _walk(module, parts[k:], module.__name__)
        return f"no module {parts[0]!r}"
    modules = class_modules().get(parts[0])
    if not modules:
        return f"no class {parts[0]!r} in {', '.join(PACKAGES)}"
    reasons = []
    for mod in modules:
        reason = _walk(importlib.import_module(mod), parts, mod)
        if reason is None:
            return None
        reasons.append(reason)
    return "; ".join(reasons)


@pytest.mark.slow  # imports every module the docs name: PyTorch, Open3D, the pipeline (about 7 s of CPU here)
def test_the_docs_name_things_that_exist() -> None:
    names = [n for path in DOCS for n in doc_names(path.read_text(encoding="utf-8"), str(path.relative_to(ROOT)))]
    assert len({n.name for n in names if n.file == "docs/ARCHITECTURE.md"}) > 60  # the check reads the doc
    unresolved = [f"{n.file}:{n.line}: `{n.name}`: {why}" for n in names if (why := resolve(n.name)) is not None]
    assert not unresolved, f"{len(unresolved)} documented names do not resolve:\n" + "\n".join(unresolved)


@pytest.mark.parametrize(("text", "expected"), [
    ("`recon.cluster.DetectedObject`", None),
    ("`StreamingClusterer.poll` and `auvlink.pipeline.engine.Engine.feed`", None),
    ("`recon.cluster.NoSuchThing`", "recon.cluster has no attribute 'NoSuchThing'"),
    ("`auvlink.no_such_module.thing`", "auvlink has no attribute 'no_such_module'"),
    ("`StreamingClusterer.renamed_method`", "has no attribute 'renamed_method'"),
    ("`NoSuchClass.method`", "no class 'NoSuchClass'"),
])
def test_a_renamed_name_is_reported(text: str, expected: str | None) -> None:
    (name,) = doc_names(text, "x.md")[-1:]
    why = resolve(name.name)
    assert (why is None) if expected is None else (why is not None and expected in why), why


def test_file_names_code_blocks_and_other_libraries_are_not_names() -> None:
    text = ("`summary.json`, `docs/ARCHITECTURE.md`, `os.cpu_count`, `LOG.mcap.partial`, `auvlink/formats.py`\n"
            "```\nrecon.gone.Module\n```\n`auvlink.Event`, `Classifier.decide`\n")
    assert [(n.name, n.line) for n in doc_names(text, "x.md")] == [("Classifier.decide", 5)]


def heading_anchors(text: str) -> set[str]:
    """GitHub's anchors of a Markdown file's headings (lower case, punctuation dropped, spaces to hyphens)."""
    return {re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
            for m in re.finditer(r"^#+ (.+)$", FENCE.sub("", text), re.M)}


def test_links_stay_inside_the_repository_and_find_their_target() -> None:
    problems = []
    for path in [*DOCS, ROOT / "CHANGELOG.md", ROOT / "benchmarks" / "RESULTS.md"]:
        for m in re.finditer(r"\]\(([^)\s]+)\)", FENCE.sub("", path.read_text(encoding="utf-8"))):
            link = m.group(1)
            if re.match(r"[a-z]+://", link):
                continue
            file, _, anchor = link.partition("#")
            target = (path.parent / file).resolve() if file else path
            where = f"{path.relative_to(ROOT)}: ({link})"
            if not target.is_relative_to(ROOT):
                problems.append(f"{where} points outside the repository")
            elif not target.exists():
                problems.append(f"{where}: no such file")
            elif anchor and target.suffix == ".md" and anchor not in heading_anchors(target.read_text("utf-8")):
                problems.append(f"{where}: no heading with that anchor")
    assert not problems, "\n".join(problems)


#: a repository path in a code span: a top folder of the repository, then at least one more part
REPO_PATH = re.compile(r"(?<![\w./~$-])((?:auvlink|logs_format|recon|classify|docs|tests|benchmarks|examples|scripts)"
                       r"/[\w./-]*)(?![\w<])")


def test_the_files_and_folders_the_docs_name_exist() -> None:
    missing = []
    for path in DOCS:
        text = FENCE.sub(lambda m: "\n" * m.group(0).count("\n"), path.read_text(encoding="utf-8"))
        for span in SPAN.finditer(text):
            for m in REPO_PATH.finditer(span.group(1)):
                name = m.group(1).rstrip(".")
                if not (ROOT / name).exists() and not (ROOT / f"{name}.py").exists():  # a module may go by its path
                    line = text.count("\n", 0, span.start()) + 1
                    missing.append(f"{path.relative_to(ROOT)}:{line}: `{name}`")
    assert not missing, "files named in the docs that do not exist:\n" + "\n".join(missing)
