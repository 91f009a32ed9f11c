"""Every command line the documents show parses with the current code.

Documents: ``README.md``, ``RESULTS.md``, ``BENCHMARKS.md``, ``docs/*.md``, ``results/README.md`` (the shipped
artefacts) and each study's ``studies/<name>/README.md``, and for their commands also the reports under ``results/``
and ``studies/`` that they cite (a result's provenance: the report named, or the one beside a named file or
in a named folder). Commands: the lines of fenced code blocks and the inline ``code`` spans that start with
``python``, ``python3``, ``torchrun``, ``bash scripts/`` or ``bash studies/`` (after ``VAR=value`` prefixes; a
fenced line joined with its ``\\`` continuations, cut at ``&&``, ``||``, ``;`` and `` | `` (a pipe between spaces: ``{a|b}`` is one word),
its ``# comment`` and a trailing `` &`` dropped; an inline span may wrap over lines). Each is
checked without running it:

- ``python train.py ARGS`` and ``torchrun [torchrun flags] train.py ARGS`` -> ``hexnewton.apps.train.main``;
  ``torchrun [torchrun flags] -m hexnewton.apps.X ARGS`` as ``python -m hexnewton.apps.X ARGS``;
  ``python play.py ARGS`` -> ``hexnewton.apps.play.main``; ``python -m hexnewton.apps.X ARGS`` ->
  ``hexnewton.apps.X.main``: the entry point's own argument parser parses
  ARGS in-process (``argparse.ArgumentParser.parse_args`` is patched to stop right after a successful parse), so a
  flag that does not exist, a wrong value or a missing argument fails with the parser's one-line message;
- ``python scripts/....py`` and ``python studies/....py``: the file exists; ``bash scripts/....sh SUB`` and
  ``bash studies/....sh SUB``: the file exists and SUB is one of its
  top-level ``case`` labels;
- ``python -m pytest``, ``python -c``, ``pip``, ``git``, ``tensorboard`` and other tools: not checked.

Placeholders (one convention for every document):

====================  ===============================================================================
in a document         parsed as
====================  ===============================================================================
``CKPT``              ``results/policies/cpg_rl_complex.pt`` (a trained policy's checkpoint)
``BUNDLE``            ``results/controllers/cpg_rl_complex`` (an exported bundle)
``DIR``               ``out`` (an output directory)
``N``                 ``2``
``T``                 ``rugged`` (a terrain)
``<word>``            ``word`` (a part of a path: ``logs/hexnewton_rugged/<run>/model_299.pt``)
``{a|b|c}``           each alternative in turn (``--task {rugged|stepped}`` is two commands)
``...``               nothing (more of the same flags)
``ARGS``, ``[FLAGS]``  nothing (a command's flags)
====================  ===============================================================================

``--resume PATH`` reads the checkpoint before the parser is built (the parser takes the checkpoint's task), so the
test parses every ``--resume`` with a run checkpoint of its own in PATH's place (the shipped complex policy with an
empty critic and optimiser).

A path ``scripts/...`` named in a code span, a link or a fenced line must exist, unless marked as below (a script that
the repository no longer holds: `` `scripts/device/scale.sh` (at e57dac3)``, readable with ``git show e57dac3:PATH``).

A historical command, a result's provenance that the current code no longer runs, is marked with the commit it ran
at, ``(at <sha>)`` (7 to 40 hex digits): right after an inline span (`` `python train.py --old_flag` (at e57dac3)``),
as the comment of a fenced line (``python train.py --old_flag   # (at e57dac3)``), or at the end of the line that
introduces a fenced block (``... ran (at e57dac3):``), which marks the whole block. A marked command is not parsed;
the mark's commit must exist where the checkout has the history.

Every ``results/...`` and ``studies/...`` path a document names must be committed (``*`` globs match a file); the
reports under ``studies/`` that a document cites are checked like those under ``results/``.
"""

from __future__ import annotations

import argparse
import contextlib
import glob
import importlib
import io
import json
import os
import re
import shlex
import subprocess
from dataclasses import dataclass

import pytest

ROOT = os.path.abspath(os.path.join(os.path.dirname(__file__), ".."))
DOCUMENTS = ["README.md", "RESULTS.md", "BENCHMARKS.md", "results/README.md"] + sorted(
    os.path.relpath(p, ROOT) for pattern in (("docs", "*.md"), ("studies", "*", "README.md"))
    for p in glob.glob(os.path.join(ROOT, *pattern))
)


def _cited_reports() -> list[str]:
    """The reports under ``results/`` that a document cites: ``results/<what>/report.md`` itself, the report of a
    folder ``results/<what>`` it names, or the report beside a file it names (``results/<what>/curves.csv.gz``). They
    hold a result's provenance, so their commands are checked like the documents'."""
    out = set()
    for doc in DOCUMENTS:
        with open(os.path.join(ROOT, doc)) as f:
            text = f.read()
        for path in re.findall(r"(?<![\w/])(?:results|studies)/[\w./-]*\w", text):
            folder = path if os.path.isdir(os.path.join(ROOT, path)) else os.path.dirname(path)
            report = path if path.endswith("report.md") else os.path.join(folder, "report.md")
            if os.path.isfile(os.path.join(ROOT, report)):
                out.add(os.path.normpath(report))
    return sorted(out)


REPORTS = _cited_reports()
PLACEHOLDERS = {"CKPT": "results/policies/cpg_rl_complex.pt", "BUNDLE": "results/controllers/cpg_rl_complex",
                "DIR": "out", "N": "2", "T": "rugged"}  # fmt: skip
MARK = re.compile(r"\(at\s+([0-9a-f]{7,40})\)")
STARTS = ("python ", "python3 ", "torchrun ", "bash scripts/", "bash studies/")
#: torchrun's flags that take no value
TORCHRUN_SWITCHES = ("--standalone", "--no-python", "--no_python", "--run-path", "--run_path")
#: fewer commands than this means the extractor is broken, not that the documents have none
MIN_COMMANDS = 80


SCRIPT = re.compile(r"(?<![\w/.])scripts/[\w./-]*\w")


@dataclass
class Command:
    doc: str
    line: int
    text: str
    at: str | None = None  # the commit of a historical command
    script: bool = False  # a reference to a file under scripts/, not a command

    def __str__(self):
        return f"{self.doc}:{self.line}: {self.text}"


def _segments(text: str) -> list[str]:
    """A shell line cut at ``&&``, ``||``, ``;`` and ``|``, ``VAR=value`` prefixes dropped, the pieces that start
    like a command the test checks."""
    out = []
    for piece in re.split(r"&&|\|\||;|\s\|\s", text):  # a pipe between spaces: {a|b} is one word
        piece = piece.strip()
        while re.match(r"^[A-Z_][A-Z0-9_]*=\S*\s", piece):
            piece = piece.split(None, 1)[1]
        piece = piece.removesuffix(" &").rstrip()  # run in the background
        if piece.startswith(STARTS):
            out.append(piece)
    return out


def _strip_comment(line: str) -> tuple[str, str]:
    """(the command, its ``# comment``): a ``#`` after white space outside quotes starts the comment."""
    quote = None
    for i, ch in enumerate(line):
        if quote:
            quote = None if ch == quote else quote
        elif ch in "'\"":
            quote = ch
        elif ch == "#" and (i == 0 or line[i - 1].isspace()):
            return line[:i].rstrip(), line[i + 1 :].strip()
    return line.rstrip(), ""


def extract(doc: str) -> list[Command]:
    """The commands of one document, in order."""
    with open(os.path.join(ROOT, doc)) as f:
        lines = f.read().split("\n")
    commands: list[Command] = []
    prose: list[tuple[int, str]] = []  # (line number, text) outside fences
    i = 0
    while i < len(lines):
        if lines[i].lstrip().startswith("```"):
            before = next((lines[j] for j in range(i - 1, -1, -1) if lines[j].strip()), "")
            block_mark = re.search(MARK.pattern + r"\s*:\s*$", before)  # "... as run (at <sha>):" marks the block
            fence, i = lines[i].lstrip()[:3], i + 1
            while i < len(lines) and not lines[i].lstrip().startswith(fence):
                start, text = i + 1, lines[i]
                while text.rstrip().endswith("\\") and i + 1 < len(lines):
                    i += 1
                    text = text.rstrip()[:-1] + " " + lines[i].strip()
                text, comment = _strip_comment(text.strip().removeprefix("$ "))
                mark = MARK.search(comment) or block_mark
                for path in SCRIPT.findall(text):
                    commands.append(Command(doc, start, path, mark.group(1) if mark else None, script=True))
                for seg in _segments(text):
                    commands.append(Command(doc, start, seg, mark.group(1) if mark else None))
                i += 1
            prose.append((i + 1, ""))  # the closing fence
        else:
            prose.append((i + 1, lines[i]))
        i += 1
    # inline spans: over the prose joined, so that a span may wrap over lines
    text = "\n".join(t for _, t in prose)
    numbers = [n for n, _ in prose]
    for m in re.finditer(r"(?<!`)`([^`]+)`(?!`)", text):
        span = " ".join(m.group(1).split())
        line = numbers[text.count("\n", 0, m.start())]
        mark = MARK.match(text[m.end() :].lstrip(" \n"))
        for seg in _segments(span):
            commands.append(Command(doc, line, seg, mark.group(1) if mark else None))
        for path in SCRIPT.findall(span):
            commands.append(Command(doc, line, path, mark.group(1) if mark else None, script=True))
    for m in re.finditer(r"\]\((scripts/[^)#\s]+)", text):  # links
        commands.append(Command(doc, numbers[text.count("\n", 0, m.start())], m.group(1), script=True))
    return sorted(commands, key=lambda c: c.line)


def expand(text: str) -> list[str]:
    """The command lines a documented one stands for (placeholders replaced; ``{a|b}`` gives one per alternative)."""
    m = re.search(r"\{([^{}]*\|[^{}]*)\}", text)
    if m:
        return [v for alt in m.group(1).split("|") for v in expand(text[: m.start()] + alt + text[m.end() :])]
    text = re.sub(r"<([^<>\s]+)>", r"\1", text)
    words = [w for w in shlex.split(text) if w not in ("...", "…", "ARGS", "[FLAGS]")]
    return [" ".join(shlex.quote(PLACEHOLDERS.get(w, w)) for w in words)]


class _Parsed(BaseException):
    """Raised by the patched ``parse_args`` after a successful parse (a BaseException: no ``except Exception`` in a
    main swallows it)."""


_REAL_PARSE_ARGS = argparse.ArgumentParser.parse_args


def _parse_then_stop(self, args=None, namespace=None):
    """``parse_args`` for one checked call: parse for real (an error exits as usual), then stop the main."""
    raise _Parsed(_REAL_PARSE_ARGS(self, args, namespace))


def _entry(words: list[str]) -> tuple[str, list[str]] | None:
    """(module whose main parses, its argv) for a command the test parses; None for one it does not."""
    if words[0] == "torchrun":  # its own flags up to the script, or up to -m and the module
        rest = words[1:]
        while rest and rest[0].startswith("-") and rest[0] != "-m":
            one = "=" in rest[0] or rest[0] in TORCHRUN_SWITCHES or len(rest) < 2 or rest[1].endswith(".py")
            rest = rest[1:] if one else rest[2:]
        words = ["python"] + rest
    if words[0] not in ("python", "python3") or len(words) < 2:
        return None
    if words[1] == "-m":
        module = words[2]
        if not module.startswith("hexnewton"):
            return None
        return module, words[3:]
    if words[1] in ("train.py", "play.py"):
        return "hexnewton.apps." + words[1][:-3], words[2:]
    return None


_RUN_CHECKPOINT: list[str] = []


def _run_checkpoint(tmp_dir: str) -> str:
    """A run checkpoint (policy, an empty critic and optimiser) for ``--resume`` to read before its parser is built."""
    if not _RUN_CHECKPOINT:
        import torch

        ckpt = torch.load(os.path.join(ROOT, PLACEHOLDERS["CKPT"]), weights_only=True, map_location="cpu")
        ckpt.update(critic_state_dict={}, optimizer_state_dict={})
        path = os.path.join(tmp_dir, "run_model.pt")
        torch.save(ckpt, path)
        _RUN_CHECKPOINT.append(path)
    return _RUN_CHECKPOINT[0]


def check(command: Command, tmp_dir: str) -> str | None:
    """None if every expansion of the command parses (or the file it runs exists); else the reason."""
    for line in expand(command.text):
        words = shlex.split(line)
        if words[0] == "bash":
            path = os.path.join(ROOT, words[1])
            if not os.path.isfile(path):
                return f"{words[1]} does not exist"
            with open(path) as f:
                labels = {
                    lab for m in re.finditer(r"^([\w|-]+)\)", f.read(), re.MULTILINE) for lab in m.group(1).split("|")
                }
            if len(words) > 2 and labels and words[2] not in labels:
                return f"{words[1]} has no subcommand '{words[2]}' (it has {', '.join(sorted(labels))})"
            continue
        if len(words) > 1 and words[1].endswith(".py") and words[1] not in ("train.py", "play.py"):
            if not os.path.isfile(os.path.join(ROOT, words[1])):
                return f"{words[1]} does not exist"
            continue
        entry = _entry(words)
        if entry is None:
            continue
        module, argv = entry
        if "--resume" in argv and argv.index("--resume") + 1 < len(argv):
            argv[argv.index("--resume") + 1] = _run_checkpoint(tmp_dir)
        try:
            main = importlib.import_module(module).main
        except ImportError as exc:
            return f"no module {module}: {exc}"
        except AttributeError:
            return f"{module} is not a command line (no main)"
        err = io.StringIO()
        argparse.ArgumentParser.parse_args = _parse_then_stop
        try:
            with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
                main(argv)
        except _Parsed:
            continue
        except SystemExit as exc:
            if exc.code in (0, None):  # --help, --list_tasks before the parse ends
                continue
            return err.getvalue().strip().splitlines()[-1] if err.getvalue().strip() else f"exit status {exc.code}"
        except Exception as exc:  # noqa: BLE001 - a checkpoint that cannot be read, a bad value ...
            return f"{type(exc).__name__}: {exc}"
        finally:
            argparse.ArgumentParser.parse_args = _REAL_PARSE_ARGS
        return f"{module}.main returned without parsing its arguments"
    return None


def _has_history() -> bool:
    """A git checkout with its full history (not a shallow clone, not an exported tree)."""
    try:
        proc = subprocess.run(
            ["git", "-C", ROOT, "rev-parse", "--is-shallow-repository"], check=False, capture_output=True, text=True
        )
    except OSError:
        return False
    return proc.returncode == 0 and proc.stdout.strip() == "false"


ALL = [c for doc in DOCUMENTS + REPORTS for c in extract(doc)]


def test_extractor_finds_the_commands():
    commands = [c for c in ALL if not c.script]
    print(
        f"{len(commands)} commands in {len(DOCUMENTS)} documents, {sum(c.at is None for c in commands)} parsed, "
        f"{sum(c.at is not None for c in commands)} historical; {len(ALL) - len(commands)} references to scripts/"
    )
    assert len(commands) > MIN_COMMANDS, "the extractor found too few commands: it is broken"
    assert any(c.doc == "README.md" and c.text.startswith("python train.py") for c in ALL)


@pytest.mark.parametrize("doc", DOCUMENTS + REPORTS)
def test_documented_commands_parse(doc, tmp_path):
    failures = []
    for command in (c for c in ALL if c.doc == doc):
        if command.at is not None:
            if _has_history():
                ok = subprocess.run(["git", "-C", ROOT, "cat-file", "-e", f"{command.at}^{{commit}}"],
                                    check=False, capture_output=True).returncode == 0  # fmt: skip
                if not ok:
                    failures.append(f"{command}\n    (at {command.at}): no such commit")
            continue
        if command.script:
            reason = None if os.path.exists(os.path.join(ROOT, command.text)) else f"{command.text} does not exist"
        else:
            reason = check(command, str(tmp_path))
        if reason is not None:
            failures.append(f"{command}\n    {reason}")
    assert not failures, f"{len(failures)} command(s) of {doc} do not parse:\n" + "\n".join(failures)


def test_cited_results_exist():
    """Every ``results/...`` and ``studies/...`` path a document names is committed (a claim goes with its evidence); ``*`` globs match
    at least one file, ``<word>`` placeholders are not checked; a kept checkpoint held in git history
    (studies/house/kept.json, its own test checks the history) counts, as does the folder it is in."""
    with open(os.path.join(ROOT, "studies", "house", "kept.json")) as f:
        held = list(json.load(f)["files"])
    missing = []
    for doc in DOCUMENTS:
        with open(os.path.join(ROOT, doc)) as f:
            for n, line in enumerate(f, 1):
                for path in re.findall(r"(?<![\w/])(?:results|studies)/[\w./*-]*[\w*]", line):
                    if "<" in line[line.find(path) + len(path) : line.find(path) + len(path) + 1]:
                        continue
                    found = (
                        glob.glob(os.path.join(ROOT, path)) if "*" in path else os.path.exists(os.path.join(ROOT, path))
                    )
                    if not found and not any(k == path or k.startswith(path.rstrip("/") + "/") for k in held):
                        missing.append(f"{doc}:{n}: {path}")
    assert not missing, "documents name results that are not in the repository:\n" + "\n".join(missing)


# --- the package's docstrings: their command lines parse, every flag they quote exists -------------------------------

PACKAGE = os.path.join(ROOT, "hexnewton")
#: flags of the tools that start a command (torchrun's), not of a hexnewton parser
TOOL_FLAGS = {"--nproc_per_node", "--nnodes", "--node_rank", "--standalone", "--rdzv_backend", "--rdzv_endpoint",
              "--rdzv_id", "--master_addr", "--master_port"}  # fmt: skip
FLAG = re.compile(r"(?<![\w-])--[A-Za-z][\w.-]*")


def _docstrings() -> list[tuple[str, int, str]]:
    """(path relative to the repository, line, text) of every module, class and function docstring of the package."""
    import ast

    out = []
    for folder, _, files in os.walk(PACKAGE):
        for f in sorted(files):
            if f.endswith(".py"):
                path = os.path.join(folder, f)
                with open(path) as fh:
                    tree = ast.parse(fh.read(), path)
                for node in ast.walk(tree):
                    if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
                        doc = ast.get_docstring(node, clean=False)
                        if doc:
                            out.append((os.path.relpath(path, ROOT), getattr(node, "lineno", 1), doc))
    return out


def _docstring_commands(doc: str) -> list[tuple[str, str | None]]:
    """(command, commit of a historical one) for each command line of a docstring: its lines that start like a
    command (joined with their ``\\`` continuations, the ``# comment`` dropped). A ``code`` span names a command
    (``python -m hexnewton.apps.export``, ``--task T``) rather than running it: its flags are checked alone."""
    out = []
    lines = doc.split("\n")
    i = 0
    while i < len(lines):
        text = lines[i].strip()
        while text.endswith("\\") and i + 1 < len(lines):
            i += 1
            text = text[:-1].rstrip() + " " + lines[i].strip()
        text, comment = _strip_comment(text)
        mark = MARK.search(comment)
        out += [(seg, mark.group(1) if mark else None) for seg in _segments(text)]
        i += 1
    return out


def _parser_flags() -> set[str]:
    """Every option string of every command line's parser (``hexnewton/apps/``, ``train.py``, ``play.py``) and of its
    subcommands; the baselines' once per algorithm, whose presets have fields of their own."""
    flags: set[str] = set()
    real_parse, real_known = argparse.ArgumentParser.parse_args, argparse.ArgumentParser.parse_known_args

    def options(parser) -> set[str]:  # a parser's own and its subcommands' (hexnewton.apps.ros node --stats)
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        return set(parser._option_string_actions).union(*(options(p) for a in subs for p in a.choices.values()))

    def parse_args(self, args=None, namespace=None):
        flags.update(options(self))
        raise _Parsed(None)

    def parse_known_args(self, args=None, namespace=None):
        flags.update(self._option_string_actions)
        return real_known(self, args, namespace)

    runs = [(name[:-3], []) for name in sorted(os.listdir(os.path.join(PACKAGE, "apps")))
            if name.endswith(".py") and name[:-3] not in ("__init__", "cli", "console")]  # fmt: skip
    runs += [("baselines", ["--algo", algo]) for algo in ("sac", "td3", "a2c")]
    argparse.ArgumentParser.parse_args, argparse.ArgumentParser.parse_known_args = parse_args, parse_known_args
    try:
        for name, argv in runs:
            main = importlib.import_module(f"hexnewton.apps.{name}").main
            with contextlib.suppress(_Parsed, SystemExit), contextlib.redirect_stdout(io.StringIO()), \
                    contextlib.redirect_stderr(io.StringIO()):  # fmt: skip
                main(list(argv))
    finally:
        argparse.ArgumentParser.parse_args, argparse.ArgumentParser.parse_known_args = real_parse, real_known
    return flags


def test_docstring_commands_parse(tmp_path):
    """Every command line a docstring of the package shows parses like the documents' (historical ones, marked with
    their commit, are skipped)."""
    failures, n = [], 0
    for path, line, doc in _docstrings():
        for text, at in _docstring_commands(doc):
            if at is not None:
                continue
            n += 1
            reason = check(Command(path, line, text), str(tmp_path))
            if reason is not None:
                failures.append(f"{path}:{line}: {text}\n    {reason}")
    assert n > 20, "too few docstring commands: the extractor is broken"
    assert not failures, f"{len(failures)} docstring command(s) do not parse:\n" + "\n".join(failures)


def test_docstring_flags_exist():
    """Every ``--flag`` a docstring of the package quotes is a flag of one of the command lines' parsers (or of
    torchrun); ``--env.<section>.<field>`` and ``--env.sim.*`` stand for the flags they start. A flag followed by a
    commit mark, ``(at <sha>)``, is historical and skipped."""
    flags = _parser_flags() | TOOL_FLAGS
    assert {"--task", "--num_envs", "--checkpoint", "--controllers", "--env.sim.frame_dt"} <= flags
    missing = []
    for path, line, doc in _docstrings():
        for m in FLAG.finditer(doc):
            flag, after = m.group(0), doc[m.end() : m.end() + 1]
            if after in "<*" and after and flag.endswith("."):  # a pattern: --env.<section>.<field>, --env.sim.*
                if not any(f.startswith(flag) for f in flags):
                    missing.append(f"{path}:{line}: {flag}{after}...")
                continue
            flag = flag.rstrip(".")
            if flag in flags or MARK.match(doc[m.end() :].lstrip("`' ")):
                continue
            missing.append(f"{path}:{line}: {flag}")
    assert not missing, "docstrings quote flags that no command line has:\n" + "\n".join(missing)


def test_relative_links_resolve():
    """Every relative link of a document (``[text](path)``, ``#anchor`` dropped) names a file or folder of the
    repository, read from the document's own folder (a link in ``docs/`` to the README is ``../README.md``)."""
    broken = []
    for doc in DOCUMENTS:
        with open(os.path.join(ROOT, doc)) as f:
            text = f.read()
        for m in re.finditer(r"\]\(([^)\s]+)\)", text):
            target = m.group(1).split("#", 1)[0]
            if not target or re.match(r"[a-z][\w+.-]*:", target):  # an anchor of its own page, a URL
                continue
            if not os.path.exists(os.path.join(ROOT, os.path.dirname(doc), target)):
                broken.append(f"{doc}:{text.count(chr(10), 0, m.start()) + 1}: {target}")
    assert not broken, "links to nothing (relative to the document's folder):\n" + "\n".join(broken)
