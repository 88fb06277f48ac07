"""Code-quality promises of the layout (README "Project tree"): ruff passes, the package is typed, the
physics in models/ is pure (no ROS, no database, no serialisation, no file I/O), no module or function
outgrows the limits the layout set (600 lines a module, 80 lines a function), imports point down the layers
README names and form no cycle, package-internal imports sit at module top (but for LAZY_IMPORTS), and
comments carry no history ("issue N", "stop N": git has it)."""
import ast
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "guide_health"
MODELS = PACKAGE / "models"

#: modules whose import means ROS, a database, a serialisation format or a bag library
IMPURE_MODULES = ("rclpy", "rosbags", "sqlite3", "apsw", "json", "yaml", "pickle", "csv", "matplotlib",
                  "diagnostic_msgs", "sensor_msgs", "geometry_msgs", "std_msgs", "rcl_interfaces")
#: calls that read or write files
FILE_IO_CALLS = ("open", "read_text", "write_text", "read_bytes", "write_bytes", "savetxt", "loadtxt", "save",
                 "load", "savez", "fromfile", "tofile", "mkdir", "unlink")


def _python_files(folder: Path) -> list[Path]:
    return sorted(p for p in folder.rglob("*.py") if "__pycache__" not in p.parts)


def _imported_modules(tree: ast.AST) -> set[str]:
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


def test_ruff_passes():
    ruff = shutil.which("ruff", path=str(Path(sys.executable).parent)) or shutil.which("ruff")
    if ruff is None:
        pytest.skip("ruff is not installed (it is in requirements.txt)")
    result = subprocess.run([ruff, "check", "--no-cache", "guide_health", "test", "bench", "launch"], cwd=ROOT,
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout[-3000:] + result.stderr[-1000:]


def test_package_is_typed():
    assert (PACKAGE / "py.typed").is_file()
    assert '"py.typed"' in (ROOT / "setup.py").read_text()


@pytest.mark.parametrize("path", _python_files(MODELS), ids=lambda p: str(p.relative_to(PACKAGE)))
def test_models_import_no_ros_storage_or_serialisation_and_do_no_file_io(path):
    tree = ast.parse(path.read_text())
    impure = {m for m in _imported_modules(tree) if m.split(".")[0] in IMPURE_MODULES}
    assert not impure, f"{path.name} imports {sorted(impure)}"
    inside = {m for m in _imported_modules(tree) if m.startswith("guide_health.")}
    allowed = ("guide_health.models", "guide_health.errors", "guide_health.runs")
    assert all(m.startswith(allowed) for m in inside), sorted(inside)
    calls = {node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
             for node in ast.walk(tree) if isinstance(node, ast.Call)}
    assert not calls & set(FILE_IO_CALLS), f"{path.name} calls {sorted(calls & set(FILE_IO_CALLS))}"


def test_importing_every_model_loads_no_ros_storage_or_bag_library():
    """Transitively too: a fresh interpreter imports every models/ module and lists what it loaded."""
    modules = [".".join(p.relative_to(ROOT).with_suffix("").parts) for p in _python_files(MODELS)]
    code = ("import importlib, json, sys\n"
            f"before = set(sys.modules)\n"
            f"for m in {modules!r}: importlib.import_module(m.removesuffix('.__init__'))\n"
            "print(json.dumps(sorted(set(sys.modules) - before)))\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    loaded = {name.split(".")[0] for name in json.loads(out.stdout)}
    forbidden = {"rclpy", "rosbags", "sqlite3", "apsw", "matplotlib", "diagnostic_msgs", "rcl_interfaces"}
    assert not loaded & forbidden, sorted(loaded & forbidden)


def test_no_module_over_600_lines_and_no_function_over_80():
    too_long = []
    for path in _python_files(PACKAGE):
        text = path.read_text()
        if text.count("\n") > 600:
            too_long.append(f"{path.relative_to(ROOT)}: {text.count(chr(10))} lines")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                length = node.end_lineno - node.lineno + 1
                if length > 80:
                    too_long.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.name}: {length} lines")
    assert not too_long, too_long


# ---------------------------------------------------------------------------------------------------------
# imports: layers, cycles, module top
# ---------------------------------------------------------------------------------------------------------

#: package-internal imports kept inside a function for start-up time: (importing file, imported module) ->
#: why, with the CPU time the import costs the importer when it is not needed (measured with
#: ``python -c "import IMPORTER; t = time.process_time(); import IMPORTED; ..."``, min of 3, loaded machine)
LAZY_IMPORTS = {
    # diagnose: imported after the child process that reads the bag has forked, so that the import overlaps
    # the read (analysis/discrepancy/duty_process.py); together 131 ms
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.model_file"): "after the fork",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.report"): "after the fork",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.selection"): "after the fork",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.workflow"): "after the fork",
    # diagnose of a machine of several axes: read in this process, one pass per axis (no fork)
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.duty"): "a machine of several axes",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.model"): "a machine of several axes",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.machine_replay"): "a machine of several axes",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.discrepancy.since"): "--since (imports the fit)",
    ("guide_health/cli/diagnose.py", "guide_health.analysis.slewing_diagnose"): "143 ms: a slewing bag",
    ("guide_health/analysis/discrepancy/duty_process.py", "guide_health.analysis.discrepancy.duty"):
        "780 ms: in the forked child (or at result()), not before the fork",
    ("guide_health/analysis/discrepancy/duty_process.py", "guide_health.analysis.discrepancy.report"):
        "176 ms: the child draws the PNG after its read",
    # a rolling guide only (a sliding guide never loads the fatigue and oil models)
    ("guide_health/models/wear/maintenance.py", "guide_health.models.rolling.rolling_guide"): "297 ms",
    # one sub-command (or one kind of bag) of a module that serves several
    ("guide_health/cli/fleet.py", "guide_health.params"): "1009 ms: fleet replay|diagnose|prior, not trend",
    ("guide_health/cli/fleet.py", "guide_health.analysis.fleet_prior"): "391 ms: fleet prior",
    ("guide_health/cli/fleet.py", "guide_health.analysis.fleet_trend_report"): "175 ms: fleet trend",
    ("guide_health/cli/life.py", "guide_health.analysis.life_signs"): "199 ms: life test",
    ("guide_health/cli/life.py", "guide_health.analysis.life_plots"): "123 ms: life test with its PNG",
    ("guide_health/cli/simulate.py", "guide_health.sim.life_test"): "141 ms: the life-test scenario",
    ("guide_health/cli/calibrate.py", "guide_health.analysis.discrepancy.selection"): "248 ms: --wear-law",
    ("guide_health/cli/contact.py", "guide_health.models.slewing.monitor"): "51 ms: contact slewing",
    ("guide_health/analysis/replay.py", "guide_health.analysis.slewing_replay"): "54 ms: a slewing bag",
    ("guide_health/analysis/report_plots.py", "guide_health.models.rolling.ball_contact"): "587 ms: rolling plot",
    ("guide_health/analysis/report_plots.py", "guide_health.models.slewing.finite_roller"): "520 ms: slewing plot",
    ("guide_health/analysis/report_plots.py", "guide_health.models.slewing.mcewen"): "the slewing plot",
    ("guide_health/analysis/fleet_report.py", "guide_health.analysis.report_plots"): "125 ms: only with PNGs",
    # optional: without it `stress_model: numerical` is a one-line ValueError (test_roller_contact)
    ("guide_health/models/slewing/monitor.py", "guide_health.models.slewing.numerical_roller"): "optional model",
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(name: str) -> bool:
    path = PACKAGE.parent / name.replace(".", "/")
    return path.with_suffix(".py").is_file() or (path / "__init__.py").is_file()


def _package_imports(path: Path) -> list[tuple[str, int, bool]]:
    """(imported guide_health module, line, at module top) of every import in `path`: relative imports
    resolved, ``from package import submodule`` as the submodule; imports under a module-level ``if
    TYPE_CHECKING:`` count as at module top."""
    tree = ast.parse(path.read_text())
    top = set()
    for node in tree.body:
        top.add(id(node))
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            top.update(id(n) for n in node.body)
    here = _module_name(path).split(".")
    package = here if path.name == "__init__.py" else here[:-1]
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else []))
            targets = [f"{base}.{a.name}" if _is_module(f"{base}.{a.name}") else base for a in node.names]
        else:
            continue
        found.extend((m, node.lineno, id(node) in top) for m in dict.fromkeys(targets)
                     if m == "guide_health" or m.startswith("guide_health."))
    return found


def _layers() -> list[set[str]]:
    """README's layer order, low to high: the line "**Layers**, low to high ...: `a`, `b` < `c` < ..."."""
    line = next(x for x in (ROOT / "README.md").read_text().splitlines() if x.startswith("**Layers**"))
    order = line.split(":", 1)[1]
    return [set(re.findall(r"`(\w+)`", level)) for level in order.split("<")]


def _layer_of(module: str, layers: list[set[str]]) -> int:
    top = module.split(".")[1] if "." in module else ""
    if top == "":
        return -1                                       # the package's own __init__ (version only)
    for rank, names in enumerate(layers):
        if top in names:
            return rank
    raise AssertionError(f"{module}: its folder {top!r} is in no layer of README's **Layers** line")


def test_readme_names_every_top_level_module_in_one_layer():
    layers = _layers()
    names = [n for level in layers for n in level]
    assert len(names) == len(set(names)) and len(layers) >= 5, layers
    tops = {p.stem for p in PACKAGE.iterdir() if (p.suffix == ".py" and p.stem != "__init__")
            or (p.is_dir() and (p / "__init__.py").is_file())}
    assert tops == set(names), (sorted(tops - set(names)), sorted(set(names) - tops))


def test_imports_point_down_the_layers():
    """No module imports a module of a higher layer (module-level and function-level imports alike)."""
    layers = _layers()
    upward = []
    for path in _python_files(PACKAGE):
        me = _module_name(path)
        for target, line, _ in _package_imports(path):
            if _layer_of(target, layers) > _layer_of(me, layers):
                upward.append(f"{path.relative_to(ROOT)}:{line} imports {target}")
    assert not upward, upward


def _import_graph() -> dict[str, set[str]]:
    modules = {_module_name(p) for p in _python_files(PACKAGE)}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for path in _python_files(PACKAGE):
        me = _module_name(path)
        graph[me].update(t for t, _, _ in _package_imports(path) if t in modules and t != me)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is not None:
                if child not in index:
                    index[child] = low[child] = len(index)
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph[child]))))
                elif child in on_stack:
                    low[node] = min(low[node], index[child])
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle():
    """No set of modules imports itself round (module-level and function-level imports alike; a package's
    ``__init__`` counts as a module)."""
    assert not _cycles(_import_graph())


def test_package_imports_at_module_top_but_the_documented_lazy_ones():
    inside = set()
    for path in _python_files(PACKAGE):
        for target, _, at_top in _package_imports(path):
            if not at_top:
                inside.add((str(path.relative_to(ROOT)), target))
    assert inside - set(LAZY_IMPORTS) == set(), sorted(inside - set(LAZY_IMPORTS))
    assert set(LAZY_IMPORTS) - inside == set(), f"listed but no longer lazy: {sorted(set(LAZY_IMPORTS) - inside)}"


# ---------------------------------------------------------------------------------------------------------
# prose
# ---------------------------------------------------------------------------------------------------------

HISTORY = re.compile(r"\b(issue|stop) [0-9]+", re.IGNORECASE)


def test_no_history_in_the_code():
    """Comments and docstrings say what and why; which issue or stop brought a line is git's to tell."""
    found = [f"{path.relative_to(ROOT)}:{number}: {line.strip()}" for path in _python_files(PACKAGE)
             for number, line in enumerate(path.read_text().splitlines(), 1) if HISTORY.search(line)]
    assert not found, found
# --- typed parameters: models never import params/, no `.get("<parameter>", fallback)` outside params/ ----------
# Every module outside params/ takes the typed objects of guide_health.params.typed (or plain numbers); the
# defaults live once, in the schema.
#: receivers of `.get` that are records, not parameter dicts, though some keys share a parameter's name (a report,
#: a saved state, a bag's data or run metadata, a fit's standard errors)
RECORD_RECEIVERS = ("state", "report", "result", "data", 'e["summary"]', 'e["result"]', "read_run_metadata(bag)",
                    "json.loads(text)", "fit.std_errors")


def _parameter_names() -> set[str]:
    from guide_health.params import SCHEMAS
    from guide_health.params.machine import AXIS_PARAMS

    return {p.name for s in SCHEMAS.values() for p in s.params} | {p.name for p in AXIS_PARAMS}


def parameter_gets(source: str, names: set[str]) -> list[str]:
    """`receiver.get("<parameter name>", ...)` calls of ``source`` whose receiver is not a record."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
                and node.args and isinstance(node.args[0], ast.Constant) and node.args[0].value in names):
            receiver = ast.get_source_segment(source, node.func.value)
            if receiver not in RECORD_RECEIVERS:
                found.append(f"{node.lineno}: {receiver}.get({node.args[0].value!r}, ...)")
    return found


def test_the_parameter_get_check_finds_a_fallback():
    names = {"alarm_clear_margin", "carriages"}
    source = 'm = params.get("alarm_clear_margin", 0.0)\nn = state.get("carriages", 1)\nk = p.get("other", 2)\n'
    assert parameter_gets(source, names) == ["1: params.get('alarm_clear_margin', ...)"]


def test_no_parameter_get_with_fallback_outside_params():
    names = _parameter_names()
    checked = [p for p in _python_files(PACKAGE) if p.relative_to(PACKAGE).parts[0] != "params"]
    assert len(checked) > 100
    found = {str(p.relative_to(PACKAGE)): parameter_gets(p.read_text(), names) for p in checked}
    assert not {k: v for k, v in found.items() if v}, found


def test_models_never_import_params():
    importing = []
    for path in _python_files(MODELS):
        tree = ast.parse(path.read_text())
        imported = _imported_modules(tree) | {f"guide_health.{a.name}" for n in ast.walk(tree)
                                              if isinstance(n, ast.ImportFrom) and n.module == "guide_health"
                                              for a in n.names}
        if any(m == "guide_health.params" or m.startswith("guide_health.params.") for m in imported):
            importing.append(path.relative_to(MODELS).as_posix())
    assert importing == []
