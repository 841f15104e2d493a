"""The layout is the architecture: layers import only downwards, no import cycles, no huge modules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: Layers, lowest first: a module may import from its own layer or any layer below it
#: (a tuple is one layer of several modules: the exceptions beside the file helpers).
LAYERS = [("euc_sim.errors", "euc_sim.io", "euc_sim.geo"), "euc_sim.stats", "euc_sim.model",
          "euc_sim.controllers", "euc_sim.simulation", "euc_sim.identification", "euc_sim.diagnosis",
          "euc_sim.rides", "euc_sim.report", "euc_sim.api", "euc_sim.cli"]
#: Inside ``euc_sim.rides``: its subpackages, lowest first (docs/architecture.md#rides-by-idea),
#: then the typed result (``result.py``) its renderers (``euc_sim.report.ride``) read;
#: ``euc_sim.rides.pipeline`` and the request it runs (``request.py``) sit above them all.
RIDES_LAYERS = ["source", "grids", "drive", "summary", "balance", "law", "sim", "rider", "compare",
                "logbook", "synth", "result"]
RIDES_FLAT = {"__init__", "result", "pipeline", "request"}
#: Upward imports allowed (none).
UPWARD_ALLOWED: set = set()
MAX_LINES = 650
#: Longest function, in lines of code (its docstring not counted).
MAX_FUNCTION_LINES = 80


def _modules() -> dict[str, Path]:
    out = {}
    for pkg in ("euc_sim",):
        for path in (ROOT / pkg).rglob("*.py"):
            parts = path.relative_to(ROOT).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            out[name] = path
    return out


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """Project modules imported anywhere in the file (function-level imports included)."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            for alias in node.names:
                full = f"{node.module}.{alias.name}"
                found.add(full if full in modules else node.module)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
    return {m for m in found if m in modules}


def _layer(module: str) -> int:
    best = -1
    for i, layer in enumerate(LAYERS):
        for prefix in (layer,) if isinstance(layer, str) else layer:
            if module == prefix or module.startswith(prefix + "."):
                best = i
    return best


GRAPH = {name: _imports(path, _modules()) for name, path in _modules().items()}


def test_every_module_has_a_layer():
    missing = [m for m in GRAPH if _layer(m) < 0 and m != "euc_sim"]
    assert missing == []


def test_layers_import_only_downwards():
    upward = [(m, d) for m, deps in GRAPH.items() for d in deps
              if m != "euc_sim" and d != "euc_sim" and _layer(d) > _layer(m) and (m, d) not in UPWARD_ALLOWED]
    assert upward == []


def test_no_import_cycles():
    # Tarjan-free check: depth-first search for a back edge
    colour, cycles = {}, []

    def visit(m, stack):
        colour[m] = 1
        for d in sorted(GRAPH[m]):
            if d == "euc_sim" or d.startswith(m + "."):
                continue
            if colour.get(d) == 1:
                cycles.append(stack[stack.index(d):] + [d] if d in stack else [m, d])
            elif d not in colour:
                visit(d, stack + [d])
        colour[m] = 2

    for m in sorted(GRAPH):
        if m not in colour:
            visit(m, [m])
    assert cycles == []


def _rides_layer(module: str) -> int | None:
    """Index of a ``euc_sim.rides`` module's subpackage in RIDES_LAYERS; len(RIDES_LAYERS) for the
    flat top (the pipeline); None outside euc_sim.rides; -1 for a subpackage not listed."""
    parts = module.split(".")
    if parts[:2] != ["euc_sim", "rides"] or len(parts) == 2:
        return None
    if len(parts) == 3 and parts[2] in RIDES_FLAT:     # the result sits below the pipeline
        return RIDES_LAYERS.index(parts[2]) if parts[2] in RIDES_LAYERS else len(RIDES_LAYERS)
    return RIDES_LAYERS.index(parts[2]) if parts[2] in RIDES_LAYERS else -1


def _rides_upward(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(importer, imported) pairs inside euc_sim.rides where a lower subpackage imports a higher one."""
    return sorted((m, d) for m, deps in graph.items() for d in deps
                  if _rides_layer(m) is not None and _rides_layer(d) is not None
                  and _rides_layer(d) > _rides_layer(m))


def _rides_subpackage_cycles(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """Pairs of rides subpackages that import each other, directly or through others."""
    sub = {}
    for m, deps in graph.items():
        for d in deps:
            a, b = m.split(".")[2:3], d.split(".")[2:3]
            if _rides_layer(m) is not None and _rides_layer(d) is not None and a != b:
                sub.setdefault(a[0], set()).add(b[0])
    reach = {a: set(bs) for a, bs in sub.items()}
    for _ in range(len(reach)):                       # transitive closure (a dozen nodes)
        for a in reach:
            reach[a] |= set().union(*(reach.get(b, set()) for b in reach[a]))
    return sorted((a, b) for a in reach for b in reach[a] if a < b and a in reach.get(b, set()))


def test_rides_has_no_flat_module_but_the_pipeline():
    rides = ROOT / "euc_sim" / "rides"
    flat = sorted(p.stem for p in rides.glob("*.py") if p.stem not in RIDES_FLAT)
    subs = sorted(p.parent.name for p in rides.glob("*/__init__.py"))
    stray = sorted(p.parent.name for p in rides.glob("*/*.py") if not (p.parent / "__init__.py").exists())
    assert flat == [], "modules flat in euc_sim/rides/ (give each a subpackage): " + ", ".join(flat)
    assert subs == sorted(set(RIDES_LAYERS) - RIDES_FLAT) and stray == []


def test_rides_subpackages_import_only_downwards():
    assert [m for m in GRAPH if _rides_layer(m) == -1] == []
    assert _rides_upward(GRAPH) == []
    assert _rides_subpackage_cycles(GRAPH) == []


def test_no_relative_imports():
    """The graph above reads absolute imports only; a relative one would slip past it."""
    rel = [f"{p.relative_to(ROOT)}:{n.lineno}" for p in _modules().values()
           for n in ast.walk(ast.parse(p.read_text())) if isinstance(n, ast.ImportFrom) and n.level]
    assert rel == []


def test_the_rides_layering_check_sees_a_violation():
    graph = {"euc_sim.rides.grids.signals": {"euc_sim.rides.compare.channels"},
             "euc_sim.rides.compare.channels": {"euc_sim.rides.grids.signals"},
             "euc_sim.rides.pipeline": {"euc_sim.rides.sim.simulate"},
             "euc_sim.rides.sim.simulate": {"euc_sim.rides.pipeline", "euc_sim.stats"}}
    assert _rides_upward(graph) == [("euc_sim.rides.grids.signals", "euc_sim.rides.compare.channels"),
                                    ("euc_sim.rides.sim.simulate", "euc_sim.rides.pipeline")]
    assert _rides_subpackage_cycles(graph) == [("compare", "grids"), ("pipeline", "sim")]


#: The rendering layer: pages, figures, the terminal's lines and the JSON, drawn from results.
RENDER = "euc_sim.report"
#: The log readers: rendering renders results, it never reads a log.
LOG_READERS = "euc_sim.rides.source.logs"
#: The ride side's faces: from ``euc_sim.rides`` they build the validated request, call the
#: pipeline and the renderers.
FACES = ("euc_sim.cli.ride", "euc_sim.cli.rides")
FACE_MAY_IMPORT = ("euc_sim.rides.request", "euc_sim.rides.pipeline", RENDER)
#: Analysis modules' imports of rendering still allowed, each with why (none: the pipeline
#: returns a typed result and writes no file).
ANALYSIS_RENDER_ALLOWED: dict = {}
#: The faces' other imports from ``euc_sim.rides``, each with why (``euc-sim rides`` has no
#: request module: what builds its request is listed here).
FACE_EXCEPTIONS = {
    ("euc_sim.cli.rides", "euc_sim.rides.source.logs"): "which files in a folder are logs (detect_layout)",
    ("euc_sim.cli.rides", "euc_sim.rides.source.spec"): "the request: --wheel's spec",
    ("euc_sim.cli.rides", "euc_sim.rides.drive.battery"): "the request: --wheel's battery pack",
    ("euc_sim.cli.rides", "euc_sim.rides.logbook.history"): "the rides command's pipeline (ride_entry, ride_history)",
}


def _within(module: str, package: str) -> bool:
    return module == package or module.startswith(package + ".")


def _analysis_imports_render(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(importer, imported): a module of euc_sim.rides, the pipeline included, importing rendering."""
    return sorted((m, d) for m, deps in graph.items() for d in deps
                  if _within(m, "euc_sim.rides") and _within(d, RENDER))


def _render_reads_logs(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(importer, imported): a rendering module importing the log readers."""
    return sorted((m, d) for m, deps in graph.items() for d in deps if _within(m, RENDER) and _within(d, LOG_READERS))


def _faces_beyond_pipeline(graph: dict[str, set[str]]) -> list[tuple[str, str]]:
    """(face, imported): a face importing from euc_sim.rides other than the pipeline and rendering."""
    return sorted((m, d) for m in FACES for d in graph.get(m, ())
                  if _within(d, "euc_sim.rides") and not any(_within(d, ok) for ok in FACE_MAY_IMPORT))


def test_analysis_never_imports_rendering():
    assert [p for p in _analysis_imports_render(GRAPH) if p not in ANALYSIS_RENDER_ALLOWED] == []
    assert sorted(set(ANALYSIS_RENDER_ALLOWED) - set(_analysis_imports_render(GRAPH))) == [], "stale exception"


def test_rendering_never_imports_the_log_readers():
    assert _render_reads_logs(GRAPH) == []


def test_the_faces_call_only_the_pipeline_and_the_renderers():
    beyond = _faces_beyond_pipeline(GRAPH)
    assert [p for p in beyond if p not in FACE_EXCEPTIONS] == []
    assert sorted(set(FACE_EXCEPTIONS) - set(beyond)) == [], "stale exception"


def test_the_rendering_rules_see_a_violation():
    graph = {"euc_sim.rides.pipeline": {"euc_sim.report.ride.page"},
             "euc_sim.rides.balance.fit": {"euc_sim.report.ride"},
             "euc_sim.report.ride.page": {"euc_sim.rides.source.logs", "euc_sim.rides.balance.fit"},
             "euc_sim.report.ride.terminal": {"euc_sim.rides.source.spec"},
             "euc_sim.rides.renderer": {"euc_sim.report.ride.page"},
             "euc_sim.cli.ride": {"euc_sim.rides.pipeline", "euc_sim.report.ride.terminal",
                                  "euc_sim.rides.balance.fit", "euc_sim.io"},
             "euc_sim.cli.rides": {"euc_sim.rides.logbook.history"}}
    assert _analysis_imports_render(graph) == [("euc_sim.rides.balance.fit", "euc_sim.report.ride"),
                                               ("euc_sim.rides.pipeline", "euc_sim.report.ride.page"),
                                               ("euc_sim.rides.renderer", "euc_sim.report.ride.page")]
    assert _render_reads_logs(graph) == [("euc_sim.report.ride.page", "euc_sim.rides.source.logs")]
    assert _faces_beyond_pipeline(graph) == [("euc_sim.cli.ride", "euc_sim.rides.balance.fit"),
                                             ("euc_sim.cli.rides", "euc_sim.rides.logbook.history")]


#: Analysis functions (fits, predictions, statistics) rendering once called again: it draws the
#: value the analysis keeps on its typed result.
RENDER_MUST_NOT_CALL = frozenset({"predict_pwm", "predict_power", "fit_pwm", "fit_battery", "fit_drivetrain",
                                  "fit_mass", "charge_drawn", "rms", "shared_offset"})


def _analysis_calls(source: str) -> list[tuple[int, str]]:
    """(line, name): where ``source`` imports or calls (``f(...)``, ``m.f(...)``) one of
    :data:`RENDER_MUST_NOT_CALL`."""
    out = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.ImportFrom):
            out += [(node.lineno, a.name) for a in node.names if a.name in RENDER_MUST_NOT_CALL]
        elif isinstance(node, ast.Call):
            f = node.func
            name = f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else None
            if name in RENDER_MUST_NOT_CALL:
                out.append((node.lineno, name))
    return out


def test_rendering_calls_no_analysis():
    calls = [(m, line, name) for m, path in sorted(_modules().items()) if _within(m, RENDER)
             for line, name in _analysis_calls(path.read_text())]
    assert calls == []


def test_the_analysis_call_check_sees_a_violation():
    src = ("from euc_sim.stats import rms\nimport euc_sim.rides.drive.drivetrain as D\n"
           "def f(tr, sig):\n    return rms(tr.nominal), D.predict_pwm(sig, {}), tr.rms_nominal\n")
    assert _analysis_calls(src) == [(1, "rms"), (4, "rms"), (4, "predict_pwm")]


#: Objects of the ride JSON (CONTRACT) an analysis once read back instead of the typed result.
RIDE_JSON_OBJECTS = frozenset({"summary", "drivetrain", "controller", "parameters", "effects", "verdict",
                               "envelope", "cutout", "selection", "selected_not_accepted", "simulation",
                               "residual_traces", "localisation", "mass_check", "compared"})


def _json_reads(source: str) -> list[tuple[int, str]]:
    """(line, key): where ``source`` reads one of :data:`RIDE_JSON_OBJECTS` from a mapping
    (``x["key"]`` or ``x.get("key")``)."""
    out = []
    for node in ast.walk(ast.parse(source)):
        key = None
        if isinstance(node, ast.Subscript) and isinstance(node.ctx, ast.Load):
            key = node.slice.value if isinstance(node.slice, ast.Constant) else None
        elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get"
              and node.args and isinstance(node.args[0], ast.Constant)):
            key = node.args[0].value
        if key in RIDE_JSON_OBJECTS:
            out.append((node.lineno, key))
    return out


def test_no_analysis_reads_the_ride_json():
    """Analyses take the typed result (:mod:`euc_sim.rides.result`); only rendering reads the JSON back."""
    reads = [(m, line, key) for m, path in sorted(_modules().items())
             if _within(m, "euc_sim.rides")
             for line, key in _json_reads(path.read_text())]
    assert reads == []


def test_the_json_read_check_sees_a_violation():
    src = 'def f(rep, ride):\n    a = rep["drivetrain"]\n    b = ride.get("controller")\n    rep["verdict"] = 1\n'
    assert _json_reads(src) == [(2, "drivetrain"), (3, "controller")]


#: Functions of ``euc_sim.rides`` still returning a bare ``dict`` -> why; to
#: shrink to empty.
BARE_DICT_PENDING: dict[str, str] = {}


def _bare_dict_returns(source: str) -> list[str]:
    """Functions (``Class.method``) annotated ``-> dict`` (``dict | None``), or unannotated
    returning a dict literal: a structure with no type, or a JSON object spelled outside
    ``euc_sim.report`` (a name -> value lookup says so: ``dict[str, float]``)."""
    def bare(a) -> bool:
        return (isinstance(a, ast.Name) and a.id == "dict"
                or isinstance(a, ast.BinOp) and (bare(a.left) or bare(a.right)))

    def literal(fn) -> bool:
        return any(isinstance(r, ast.Return) and (isinstance(r.value, (ast.Dict, ast.DictComp)) or (
            isinstance(r.value, ast.Call) and getattr(r.value.func, "id", None) == "dict")) for r in ast.walk(fn))

    def walk(node, prefix: str):
        for ch in ast.iter_child_nodes(node):
            if isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef)):
                if bare(ch.returns) or (ch.returns is None and literal(ch)):
                    yield prefix + ch.name
                yield from walk(ch, prefix + ch.name + ".")
            elif isinstance(ch, ast.ClassDef):
                yield from walk(ch, prefix + ch.name + ".")
    return list(walk(ast.parse(source), ""))


def test_no_bare_dict_returns_in_the_analyses():
    """An analysis returns its typed object; the ride JSON is spelled in ``euc_sim.report`` alone."""
    found = {f"{m}:{f}" for m, path in _modules().items() if _within(m, "euc_sim.rides")
             for f in _bare_dict_returns(path.read_text())}
    assert sorted(found - set(BARE_DICT_PENDING)) == []
    assert sorted(set(BARE_DICT_PENDING) - found) == [], "done: remove from BARE_DICT_PENDING"


def test_the_bare_dict_check_sees_a_violation():
    src = ("def a() -> dict:\n    return {}\ndef b() -> dict | None:\n    return None\n"
           "def c():\n    return dict(x=1)\ndef d() -> dict[str, float]:\n    return {}\n"
           "class K:\n    def e(self):\n        return {k: 1 for k in 'ab'}\n    def f(self) -> list:\n        return []\n")
    assert _bare_dict_returns(src) == ["a", "b", "c", "K.e"]


@pytest.mark.parametrize("name", sorted(_modules()))
def test_no_module_over_the_limit(name):
    n = len(_modules()[name].read_text().splitlines())
    assert n <= MAX_LINES, f"{name}: {n} lines"


def _code_lines(fn: ast.FunctionDef | ast.AsyncFunctionDef) -> int:
    """Lines from the def to the end, less the docstring."""
    first = fn.body[0]
    doc = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str)
    return fn.end_lineno - fn.lineno + 1 - ((first.end_lineno - first.lineno + 1) if doc else 0)


@pytest.mark.parametrize("name", sorted(_modules()))
def test_no_function_over_the_limit(name):
    tree = ast.parse(_modules()[name].read_text())
    long = [(fn.name, _code_lines(fn)) for fn in ast.walk(tree)
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)) and _code_lines(fn) > MAX_FUNCTION_LINES]
    assert long == []


# --- scripts/, studies/ and tests/ stay apart; the CLI's privates stay inside it ----------------
def _python_files(*folders: str) -> list[Path]:
    return sorted(p for f in folders for p in (ROOT / f).rglob("*.py"))


def _imported_names(path: Path) -> set[str]:
    """Every module an ``import`` or ``from ... import`` of the file names (all levels)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
        elif isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
    return names


#: The folders whose modules tests import by name; tests/conftest.py alone puts them on sys.path.
SCRIPT_FOLDERS = ("scripts", "scripts/tables", "studies")


def test_tests_import_scripts_and_studies_only_by_name():
    """A script's or study's module is imported by its name (``import blind_study``), the
    folder put on the path by tests/conftest.py only: never as a file, nor as ``scripts.x``."""
    importable = {p.stem for f in SCRIPT_FOLDERS for p in (ROOT / f).glob("*.py")}
    others = {p.stem for p in _python_files("scripts", "studies")} - importable
    conftest = ROOT / "tests" / "conftest.py"
    bad = []
    for path in _python_files("tests"):
        if path in (Path(__file__).resolve(), conftest):
            continue
        text = path.read_text()
        bad += [f"{path.relative_to(ROOT)}: imports {n}" for n in _imported_names(path)
                if n.split(".")[0] in others | {"scripts", "studies"}]
        if "spec_from_file_location" in text:
            bad.append(f"{path.relative_to(ROOT)}: loads a file as a module")
        if "sys.path" in text and ('"scripts"' in text or '"studies"' in text):
            bad.append(f"{path.relative_to(ROOT)}: puts scripts/ or studies/ on sys.path")
    assert bad == [], "tests import scripts' and studies' modules by name only: " + "; ".join(bad)


def test_script_modules_do_not_shadow_each_other():
    """One name, one module, over the folders tests/conftest.py puts on the path and tests/."""
    stems = [p.stem for f in (*SCRIPT_FOLDERS, "tests", "tests/rides") for p in (ROOT / f).glob("*.py") if p.stem != "conftest"]
    assert sorted({s for s in stems if stems.count(s) > 1}) == []


def test_scripts_and_studies_do_not_import_tests():
    bad = [f"{p.relative_to(ROOT)}: imports {n}" for p in _python_files("scripts", "studies")
           for n in _imported_names(p) if n == "tests" or n.startswith("tests.")]
    bad += [f"{p.relative_to(ROOT)}: puts tests/ on sys.path" for p in _python_files("scripts", "studies")
            if "sys.path" in p.read_text() and '"tests"' in p.read_text()]
    assert bad == []


def test_no_cli_private_is_imported_outside_the_cli():
    bad = []
    for path in _python_files("euc_sim", "scripts", "studies", "tests"):
        if (ROOT / "euc_sim" / "cli") in path.parents:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("euc_sim.cli"):
                bad += [f"{path.relative_to(ROOT)}: {node.module}.{a.name}" for a in node.names
                        if a.name.startswith("_")]
    assert bad == [], "CLI privates imported outside euc_sim/cli: " + ", ".join(bad)


def test_the_checks_above_see_a_violation(tmp_path):
    """The import reader finds a tests.* import and a CLI private, function-level ones included."""
    f = tmp_path / "x.py"
    f.write_text("def g():\n    from tests.rides.drivesynth import x\n    from euc_sim.cli.ride import _y\n")
    assert {"tests.rides.drivesynth", "euc_sim.cli.ride"} <= _imported_names(f)


# --- imports at module top; a function imports only what is heavy, and says so ------------------
#: Third-party modules a function may import without a marker: each adds 0.1 s or more to an
#: import (measured after numpy, pandas and mujoco, ``python -c "import X"``, best of 3):
#: scipy.signal 1.1 s, scipy.stats 0.7, scipy.interpolate 0.6, scipy.integrate 0.4, scipy.optimize
#: 0.4, scipy.linalg 0.3, scipy.ndimage 0.2; matplotlib 0.3 (lines), matplotlib.figure 0.6 more;
#: control 1.6; sympy 0.8; mujoco.sysid 0.7; distributed 0.3; numba 0.3; pandas 0.3 (alone);
#: mujoco 0.1; dask 0.1; plotly.subplots 0.1 (plotly's other modules load lazily: a few ms).
HEAVY_IMPORTS = ("scipy", "matplotlib", "control", "sympy", "mujoco", "distributed", "numba", "pandas", "dask",
                 "plotly.subplots")
#: What a function-level import of anything else carries at the end of its statement: what it
#: would load at module top and its cost, e.g. ``# deferred: loads numba (0.3 s)``.
DEFERRED = "# deferred:"
#: Where the rule holds (folders or files).
IMPORTS_AT_TOP = ["euc_sim"]
#: Folders or files inside IMPORTS_AT_TOP not done yet (none).
IMPORTS_PENDING: set = set()


def _undeclared_deferred(path: Path) -> list[str]:
    """``file:line`` of each import inside a function that is neither heavy nor marked deferred."""
    src = path.read_text()
    lines, bad = src.splitlines(), []

    def heavy(module: str) -> bool:
        return any(module == h or module.startswith(h + ".") for h in HEAVY_IMPORTS)

    def walk(node, in_function: bool):
        for ch in ast.iter_child_nodes(node):
            if in_function and isinstance(ch, (ast.Import, ast.ImportFrom)):
                mods = [a.name for a in ch.names] if isinstance(ch, ast.Import) else [ch.module or ""]
                if not all(heavy(m) for m in mods) and DEFERRED not in lines[ch.end_lineno - 1]:
                    bad.append(f"{path.relative_to(path.parents[1])}:{ch.lineno}")
            walk(ch, in_function or isinstance(ch, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)))
    walk(ast.parse(src), False)
    return bad


def test_function_level_imports_are_heavy_or_say_why():
    files = [p for s in IMPORTS_AT_TOP for p in ((ROOT / s).rglob("*.py") if (ROOT / s).is_dir() else [ROOT / s])]
    pending = tuple(IMPORTS_PENDING)
    bad = [b for p in sorted(files) if not any(p.relative_to(ROOT).is_relative_to(q) for q in pending)
           for b in _undeclared_deferred(p)]
    assert bad == [], ("imports inside functions, neither heavy (HEAVY_IMPORTS) nor marked "
                       f"'{DEFERRED} loads X (t s)': " + ", ".join(bad))


def test_the_deferred_import_check_sees_a_violation(tmp_path):
    f = tmp_path / "x.py"
    f.write_text("import json\n\n\ndef g():\n    import os\n    from scipy.signal import lfilter\n"
                 "    from euc_sim.io import write_text  # deferred: loads nothing (0 s)\n"
                 "    from euc_sim.stats import (gram_lstsq,\n                               label_grams)\n"
                 "    import matplotlib.figure, json\n")
    assert [b.split("/")[-1] for b in _undeclared_deferred(f)] == ["x.py:5", "x.py:8", "x.py:10"]
