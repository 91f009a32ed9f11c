"""The package's house rules, read from its source (AST) and checked in a few fresh interpreters: layers as folders
whose imports only go down, no circles, no private names across modules, every command line in ``apps/`` and nothing
else there, light command-line start-up (``--help`` and argument errors without Warp or Newton), a deployment runtime
without Warp, Newton or torch, short functions and modules, console scripts that answer as their python commands."""

import ast
import json
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PACKAGE = os.path.join(ROOT, "hexnewton")
#: the longest function or method allowed in the package (def line to last line, decorators excluded)
MAX_FUNCTION_LINES = 80
#: the longest module allowed in the package, in lines
MAX_MODULE_LINES = 600
#: command-line modules without a ``main`` of their own: the argument parsing shared by the command lines, the
#: console scripts
COMMAND_LINE_HELPERS = {"hexnewton.apps.cli", "hexnewton.apps.console"}
#: the layers, bottom up: a module imports modules of its own layer or of layers below it ("" is the package's root:
#: configuration, the robot's description among it, errors, start-up timing). The physics level is four rooms, one-way
#: among themselves too: the robot's builder, loader and named robots (``robot``), the terrains (``terrain``), the
#: step's kernels beside their NumPy twins (``kernels``: the CPG and mapping, the world's, the events'), the batched
#: world (``physics``)
LAYERS = ("", "robot", "terrain", "kernels", "physics", "deploy", "mdp", "learning", "tasks", "analysis", "apps")
HEAVY = ("warp", "newton")


def _module_name(path: str) -> str:
    name = os.path.relpath(path, ROOT)[: -len(".py")].replace(os.sep, ".")
    return name[: -len(".__init__")] if name.endswith(".__init__") else name


def _modules() -> dict[str, str]:
    """{module name: path} of every module of the package (a package's ``__init__.py`` is the package itself)."""
    out = {}
    for folder, _, files in os.walk(PACKAGE):
        for f in files:
            if f.endswith(".py"):
                out[_module_name(os.path.join(folder, f))] = os.path.join(folder, f)
    return out


MODULES = _modules()
TREES = {name: ast.parse(open(path).read(), path) for name, path in MODULES.items()}


def _imports(name: str) -> list[tuple[str, str | None, int]]:
    """(imported hexnewton module, imported name or None for the module itself, line) of every import statement in
    module ``name``, function-local ones included."""
    path = MODULES[name]
    package = name if path.endswith("__init__.py") else name.rpartition(".")[0]
    out = []
    for node in ast.walk(TREES[name]):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names if a.name.split(".")[0] == "hexnewton"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            if base.split(".")[0] != "hexnewton":
                continue
            for a in node.names:
                sub = f"{base}.{a.name}"
                out.append((sub, None, node.lineno) if sub in MODULES else (base, a.name, node.lineno))
    return out


GRAPH = {name: {target for target, _, _ in _imports(name) if target in MODULES and target != name} for name in MODULES}
COMMAND_LINES = {name for name, tree in TREES.items() if any(
    isinstance(n, ast.FunctionDef) and n.name == "main" for n in tree.body)} | COMMAND_LINE_HELPERS  # fmt: skip


def _layer(name: str) -> str:
    parts = name.split(".")
    return parts[1] if len(parts) > 2 or name in ("hexnewton." + layer for layer in LAYERS) else ""


def test_every_import_resolves():
    """The checks below see every arrow: each import of a hexnewton module names a module of the package."""
    missing = [f"{name}:{line} imports {target}" for name in MODULES for target, _, line in _imports(name)
               if target not in MODULES]  # fmt: skip
    assert not missing, missing


def test_no_import_cycle():
    """The modules' imports (function-local ones too) form no circle."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    path: list[str] = []
    cycles = []

    def visit(name: str) -> None:
        state[name] = 1
        path.append(name)
        for target in sorted(GRAPH[name]):
            if state.get(target) == 1:
                cycles.append(" -> ".join(path[path.index(target):] + [target]))
            elif target not in state:
                visit(target)
        path.pop()
        state[name] = 2

    for name in sorted(MODULES):
        if name not in state:
            visit(name)
    assert not cycles, cycles


def test_no_private_name_imported_from_another_module():
    private = [f"{name}:{line} imports {target}.{what}" for name in MODULES for target, what, line in _imports(name)
               if what is not None and what.startswith("_")]  # fmt: skip
    assert not private, private


def test_every_module_sits_in_a_layer_and_imports_only_go_down():
    """Each module is in one of the layer folders (or is the root's configuration, robot description, errors, start-up
    timing); it imports modules of its own layer or of a lower one, never of a higher one."""
    assert {_layer(name) for name in MODULES} == set(LAYERS)
    assert {name for name in MODULES if _layer(name) == ""} == {"hexnewton", "hexnewton.config", "hexnewton.errors",
                                                                 "hexnewton.robot_config", "hexnewton.startup"}
    rank = {layer: k for k, layer in enumerate(LAYERS)}
    up = [f"{name}:{line} ({_layer(name) or 'root'}) imports {target} ({_layer(target)})" for name in sorted(MODULES)
          for target, _, line in _imports(name) if target in MODULES and rank[_layer(target)] > rank[_layer(name)]]
    assert not up, up


def test_command_lines_live_in_apps():
    """Every module with a ``main`` is a command line in ``hexnewton/apps/``, and ``apps/`` holds nothing else."""
    apps = {name for name in MODULES if _layer(name) == "apps"} - {"hexnewton.apps"}
    assert COMMAND_LINES == apps


def test_library_modules_import_no_command_line_module():
    """Only command lines import command lines (and ``cli``, their argument parsing)."""
    assert {"hexnewton.apps.train", "hexnewton.apps.evaluate", "hexnewton.apps.baselines", "hexnewton.apps.cli"} <= COMMAND_LINES
    wrong = [f"{name}:{line} imports {target}" for name in sorted(set(MODULES) - COMMAND_LINES)
             for target, _, line in _imports(name) if target in COMMAND_LINES]  # fmt: skip
    assert not wrong, wrong


def test_functions_are_short():
    long = []
    for name, tree in TREES.items():
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{name}:{node.lineno} {node.name} ({lines} lines)")
    assert not long, f"longer than {MAX_FUNCTION_LINES} lines: {long}"


def test_modules_are_short():
    long = []
    for path in MODULES.values():
        rel = os.path.relpath(path, ROOT).replace(os.sep, "/")
        with open(path) as f:
            lines = len(f.read().splitlines())
        if lines > MAX_MODULE_LINES:
            long.append(f"{rel} ({lines} lines)")
    assert not long, f"longer than {MAX_MODULE_LINES} lines: {long}"


def _python(code: str) -> dict:
    """Run ``code`` in a fresh interpreter in the repository root; its last stdout line, as JSON."""
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_import_hexnewton_loads_neither_warp_nor_newton():
    loaded = _python("import json, sys\nimport hexnewton\n"
                     f"print(json.dumps([m for m in {HEAVY!r} if m in sys.modules]))")  # fmt: skip
    assert loaded == []


#: each command line: (how to run it, a bad argument)
CLIS = {"train.py": ("path", ["--num_envs", "-1"]), "play.py": ("path", ["--num_envs", "-1"])}
CLIS.update({name: ("module", ["--not_a_flag", "1"]) for name in sorted(COMMAND_LINES - COMMAND_LINE_HELPERS)})
CLI_PROBE = """
import contextlib, io, json, runpy, sys

how, target, cases = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
out = []
for argv in cases:
    sys.argv = [target, *argv]
    err, code = io.StringIO(), None
    with contextlib.redirect_stdout(io.StringIO()) as text, contextlib.redirect_stderr(err):
        try:
            runpy.run_path(target, run_name="__main__") if how == "path" else runpy.run_module(
                target, run_name="__main__", alter_sys=True)
        except SystemExit as exc:
            code = exc.code
    out.append({"argv": argv, "code": code, "stdout": text.getvalue(), "stderr": err.getvalue(),
                "loaded": [m for m in HEAVY if m in sys.modules]})
print(json.dumps(out))
"""


@pytest.mark.parametrize("cli", list(CLIS))
def test_command_line_help_and_argument_errors_load_neither_warp_nor_newton(cli):
    """``--help`` prints the usage and exits 0; a bad argument is one stderr line and exit status 2, no traceback;
    neither imports Warp or Newton (the heavy imports wait until the arguments are parsed)."""
    how, bad = CLIS[cli]
    cases = [["--help"], bad] + ([["--task", "complex", "--help"]] if cli == "train.py" else [])
    code = f"HEAVY = {HEAVY!r}\n" + CLI_PROBE
    proc = subprocess.run([sys.executable, "-c", code, how, cli, json.dumps(cases)], capture_output=True, text=True,
                          timeout=300, cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    help_, error, *more = json.loads(proc.stdout.strip().splitlines()[-1])
    for case in (help_, *more):
        assert case["code"] in (0, None) and "usage:" in case["stdout"], case
        assert case["loaded"] == [], case
    assert error["code"] == 2 and error["loaded"] == [], error
    lines = error["stderr"].strip().splitlines()
    assert len(lines) == 1 and ": error: " in lines[0] and "Traceback" not in error["stderr"], error["stderr"]
    if more:  # the task registry answers without Warp: the task's own values are the defaults shown
        assert "--env.terrain.name" in more[0]["stdout"] and "complex" in more[0]["stdout"]


def _console_scripts() -> dict[str, str]:
    """pyproject.toml's ``[project.scripts]``: {script: "module:function"}."""
    import tomllib

    with open(os.path.join(ROOT, "pyproject.toml"), "rb") as f:
        return tomllib.load(f)["project"]["scripts"]


#: console script -> the python command it answers as
CONSOLE_SCRIPTS = {"hexnewton-train": "train.py", "hexnewton-play": "play.py",
                   "hexnewton-evaluate": "hexnewton.apps.evaluate", "hexnewton-export": "hexnewton.apps.export",
                   "hexnewton-bench": "hexnewton.apps.bench", "hexnewton-ros": "hexnewton.apps.ros"}  # fmt: skip
SCRIPT_PROBE = """
import contextlib, importlib, io, json, runpy, sys, warnings

# runpy's notice that the module ran before (the other way imported it) is no output of the command
warnings.filterwarnings("ignore", message=".* found in sys.modules after import of package")
entry, how, target, cases = sys.argv[1], sys.argv[2], sys.argv[3], json.loads(sys.argv[4])
module, function = entry.split(":")
out = []
for argv in cases:
    answers = []
    for way in ("script", "python"):
        sys.argv = ["x" if way == "script" else target, *argv]
        err, code = io.StringIO(), None
        with contextlib.redirect_stdout(io.StringIO()) as text, contextlib.redirect_stderr(err):
            try:
                if way == "script":  # what the installed script runs: sys.exit(function())
                    code = getattr(importlib.import_module(module), function)()
                else:
                    runpy.run_path(target, run_name="__main__") if how == "path" else runpy.run_module(
                        target, run_name="__main__", alter_sys=True)
            except SystemExit as exc:
                code = exc.code
        answers.append({"code": code or 0, "stdout": text.getvalue(), "stderr": err.getvalue()})
    out.append({"argv": argv, "script": answers[0], "python": answers[1],
                "loaded": [m for m in HEAVY if m in sys.modules]})
print(json.dumps(out))
"""


def test_console_scripts_are_the_python_commands():
    """Every console script of pyproject.toml names a function that exists, and each command line has one."""
    import importlib

    scripts = _console_scripts()
    assert set(scripts) == set(CONSOLE_SCRIPTS), sorted(scripts)
    for entry in scripts.values():
        module, function = entry.split(":")
        assert callable(getattr(importlib.import_module(module), function, None)), entry


@pytest.mark.parametrize("script", sorted(CONSOLE_SCRIPTS))
def test_console_script_answers_as_its_python_command(script):
    """``--help``, a bad flag and (``hexnewton-train``) a missing checkpoint: the console script's output and exit
    status are its python command's (usage and exit 0; one stderr line and exit 2), without Warp or Newton."""
    target = CONSOLE_SCRIPTS[script]
    how = "path" if target.endswith(".py") else "module"
    cases = [["--help"], ["--not_a_flag", "1"]] + ([["--resume", "no_such.pt"]] if script == "hexnewton-train" else [])
    proc = subprocess.run([sys.executable, "-c", f"HEAVY = {HEAVY!r}\n" + SCRIPT_PROBE, _console_scripts()[script],
                           how, target, json.dumps(cases)], capture_output=True, text=True, timeout=300,
                          cwd=ROOT)  # fmt: skip
    assert proc.returncode == 0, proc.stderr[-3000:]
    help_, *errors = json.loads(proc.stdout.strip().splitlines()[-1])
    for case in (help_, *errors):
        assert case["script"] == case["python"] and case["loaded"] == [], case
    assert help_["script"]["code"] == 0 and "usage:" in help_["script"]["stdout"], help_
    for case in errors:
        lines = case["script"]["stderr"].strip().splitlines()
        assert case["script"]["code"] == 2 and len(lines) == 1 and ": error: " in lines[0], case


def test_deploy_runtime_loads_neither_warp_newton_nor_torch():
    """``import hexnewton.deploy.runtime`` and its controllers (a bundle with its ONNX policy, a fixed gait's spec) run on
    NumPy and onnxruntime alone; its replay command's ``--help`` too."""
    from hexnewton.analysis.sim2sim import fixed_cpg_spec

    bundle = os.path.join(ROOT, "results", "controllers", "cpg_rl_flat")
    code = (
        "import json, sys\n"
        "from hexnewton.apps import deploy\n"
        "from hexnewton.deploy import runtime\n"
        f"runtime.Controller(json.loads({json.dumps(json.dumps(fixed_cpg_spec()))}), num_robots=2)\n"
        f"if {os.path.isdir(bundle)!r}: runtime.Controller({bundle!r}, num_robots=2)\n"
        "try:\n"
        "    deploy.main(['--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        f"print(json.dumps([m for m in {(*HEAVY, 'torch')!r} if m in sys.modules]))\n"
    )
    assert _python(code) == []


def _kernel_files(obj, seen: set) -> set[str]:
    """The source files of a Warp kernel or function and of every Warp function it calls, directly or through a term
    table's rows (``wp.static(TABLE[k].func)``), read from the names its code uses."""
    import inspect
    import types

    import warp as wp

    if id(obj) in seen:
        return set()
    seen.add(id(obj))
    func = obj.func
    files = {inspect.getsourcefile(func)}
    cells = dict(zip(func.__code__.co_freevars, (c.cell_contents for c in func.__closure__ or ())))
    codes, names = [func.__code__], set()
    while codes:
        code = codes.pop()
        names |= set(code.co_names) | set(code.co_freevars)
        codes += [c for c in code.co_consts if isinstance(c, types.CodeType)]
    for name in names:
        value = cells.get(name, func.__globals__.get(name))
        rows = value if isinstance(value, (tuple, list)) else (value,)
        for row in rows:
            target = row if isinstance(row, (wp.Function, wp.Kernel)) else getattr(row, "func", None)
            if isinstance(target, wp.Kernel) or (isinstance(target, wp.Function) and not target.is_builtin()):
                files |= _kernel_files(target, seen)
    return files


def test_one_control_step_passes_the_files_the_internals_name():
    """docs/internals.md's "How one control step flows" names exactly the package files whose code one ``env.step`` runs
    (Python called, Warp kernels launched and the Warp functions they call), at most five, with every part of the step
    switched on: the body posture and reflex, domain randomisation, the terrain curriculum, the observation switches
    (gyro, last actions, the critic's group). A package the section names
    as a folder (``hexnewton/mdp/terms/``) counts as one, for all its files."""
    import re

    import numpy as np
    import torch
    import warp as wp

    from hexnewton.config import CPGConfig, HexConfig, ObsConfig, RandomizationConfig, SimConfig, TerrainConfig
    from hexnewton.mdp.env import make_env

    cfg = HexConfig(sim=SimConfig(num_envs=4, device="cpu", use_graph=False, frame_dt=0.02, substeps=2),
                    terrain=TerrainConfig(name="complex", levels=2, start_levels=1),
                    cpg=CPGConfig(posture=True, posture_reflex=2.0),
                    randomization=RandomizationConfig(enabled=True, push_interval=0.02),
                    obs=ObsConfig(gyro=True, last_action=True, critic=True))  # fmt: skip
    env = make_env(cfg)
    actions = torch.zeros(env.num_envs, env.num_actions)
    env.step(actions)
    package = os.path.join(ROOT, "hexnewton") + os.sep
    called, launched = set(), []

    def profile(frame, event, arg):
        if event == "call" and frame.f_code.co_filename.startswith(package):
            called.add(frame.f_code.co_filename)

    real_launch = wp.launch

    def launch(kernel, *args, **kwargs):
        launched.append(kernel)
        return real_launch(kernel, *args, **kwargs)

    wp.launch = launch
    sys.setprofile(profile)
    try:
        env.step(actions)
    finally:
        sys.setprofile(None)
        wp.launch = real_launch
    seen: set = set()
    files = called | {f for k in launched for f in _kernel_files(k, seen)}
    files = {os.path.relpath(f, ROOT) for f in files if f.startswith(package)}
    internals = open(os.path.join(ROOT, "docs", "internals.md")).read()
    section = internals.split("## How one control step flows", 1)[1].split("\n## ", 1)[0]
    named = set(re.findall(r"hexnewton/[\w/]+(?:\.py|/)", section))
    files = {next((p for p in named if p.endswith("/") and f.startswith(p)), f) for f in files}
    assert files == named and len(files) <= 5, (sorted(files), sorted(named))
    assert np.isfinite(env.obs.numpy()).all()


#: what ``results/`` holds: the shipped artefacts (policies, their deployment bundles, the videos) and its README table
SHIPPED = {"README.md", "policies", "controllers", "videos"}


def test_results_holds_only_shipped_artefacts():
    """``results/`` holds the shipped policies, bundles and videos with its README table; every experiment, with its
    reports, lives in its study (``studies/<name>/``)."""
    results = os.path.join(ROOT, "results")
    other = sorted(set(os.listdir(results)) - SHIPPED)
    assert not other, f"results/ holds more than the shipped artefacts {sorted(SHIPPED)}: {other} (a study's folder)"
    reports = [os.path.relpath(os.path.join(d, f), ROOT) for d, _, files in os.walk(results) for f in files
               if f == "report.md" and os.path.dirname(os.path.join(d, f)) != os.path.join(results, "videos")]
    assert not reports, f"reports under results/ (each belongs in its study): {reports}"


#: the README's longest length, in lines: what it is, set-up, quick start, tasks, layout, links (the evidence lives in
#: RESULTS.md, BENCHMARKS.md and docs/)
MAX_README_LINES = 130
#: the longest RESULTS.md and BENCHMARKS.md may be, in lines: one page each, every row linking its study
MAX_PAGE_LINES = 150


def test_readme_is_short():
    with open(os.path.join(ROOT, "README.md")) as f:
        lines = f.read().splitlines()
    assert len(lines) <= MAX_README_LINES, f"README.md has {len(lines)} lines (at most {MAX_README_LINES})"


@pytest.mark.parametrize("doc", ["RESULTS.md", "BENCHMARKS.md"])
def test_results_and_benchmarks_are_one_page_whose_rows_link_their_study(doc):
    """RESULTS.md and BENCHMARKS.md are one page each (the detail lives in the studies), and every row of their
    tables links the study that holds its numbers (``studies/<name>/``)."""
    with open(os.path.join(ROOT, doc)) as f:
        lines = f.read().splitlines()
    assert len(lines) <= MAX_PAGE_LINES, f"{doc} has {len(lines)} lines (at most {MAX_PAGE_LINES})"
    rows = [(n, line) for n, line in enumerate(lines, 1) if line.startswith("|") and not set(line) <= set("|-: ")]
    headers = {n for n, line in rows if n < len(lines) and set(lines[n]) <= set("|-: ")}  # a row above |---|
    unlinked = [f"{doc}:{n}" for n, line in rows if n not in headers and "](studies/" not in line]
    assert rows and not unlinked, f"table rows that link no study: {unlinked}"


def test_the_package_imports_nothing_from_studies():
    """``studies/`` (one folder per experiment: its scripts, report and tests) imports the package, never the
    reverse."""
    def imports_studies(node) -> bool:
        if isinstance(node, ast.Import):
            return any(a.name.split(".")[0] == "studies" for a in node.names)
        return isinstance(node, ast.ImportFrom) and not node.level and (node.module or "").split(".")[0] == "studies"

    found = [f"{name}:{node.lineno}" for name, tree in TREES.items() for node in ast.walk(tree) if imports_studies(node)]
    assert not found, f"package modules that import from studies/: {found}"


def test_results_readme_lists_every_shipped_policy():
    """``results/README.md``'s table has a row for every checkpoint in ``results/policies/``."""
    with open(os.path.join(ROOT, "results", "README.md")) as f:
        text = f.read()
    policies = sorted(f[: -len(".pt")] for f in os.listdir(os.path.join(ROOT, "results", "policies")) if f.endswith(".pt"))
    missing = [p for p in policies if f"| `{p}` |" not in text]
    assert not missing, f"results/README.md has no row for {missing}"
