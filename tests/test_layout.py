"""The package layout: layers import only downwards, no import circles, a small top level, short modules.

The layers, lowest first (see README, "Architecture"): foundations, the
estimation core (Kalman kernels, then SDP), signal processing,
identification, plants, data, control, studies, command line. A module may
import from its own layer and the layers below it, never from above, and
never from the `jaxsdp` facade (`jaxsdp/__init__.py`), which only re-exports.
No module imports a private (`_`-prefixed) name of any other module, in its
own subpackage or another; private *modules* (`jaxsdp._idim.iv`) are the
internal API and may be imported from above. The imports form no circle,
function-level imports included (`test_no_import_circles` states the rule).
"""

import ast
import pathlib

import pytest

import jaxsdp

PACKAGE = pathlib.Path(jaxsdp.__file__).parent
LAYERS = (
    (
        "jaxsdp._version",
        "jaxsdp._runtime",
        "jaxsdp._checks",
        "jaxsdp._records",
        "jaxsdp._io",
        "jaxsdp._scan",
        "jaxsdp._linalg",
        "jaxsdp._montecarlo",
    ),
    ("jaxsdp._kalman",),
    ("jaxsdp._sdp",),
    ("jaxsdp._signal",),
    (
        "jaxsdp._idim",
        "jaxsdp.tfest",
        "jaxsdp.tvp",
    ),  # identification: regressions (IDIM), transfer functions, time-variable models
    ("jaxsdp.plants",),
    ("jaxsdp.data",),
    ("jaxsdp.control",),  # controllers and their design (the control issue)
    ("jaxsdp.studies",),
    ("jaxsdp._cli", "jaxsdp.__main__"),
)
# 60 until issue 41 added the two types a notebook user must be able to catch or filter at the top level,
# Float64Error (a jaxsdp call traced with 64-bit mode off) and Float64Warning (float32 inputs); 62 until
# issue 44 added the option objects a pipeline is configured with, as optimistix has its solvers at its top
# level: Preprocessing, Butterworth, Smoothing, IDIMLS, IDIMIV, IID, NeweyWest, Backfitting, MLNVR, FixedNVR,
# and the IV's result IVFit; 74 when the EMPS study's CAPTAIN-style NVR search became an NVR option,
# CaptainNVR, beside MLNVR and FixedNVR (an option of Backfitting like them, so at the top level with them);
# 75 when the TX40 study's multi-SDP keywords became MultiBackfitting, the option object of multi_sdp, beside
# Backfitting (the option object of sdp) at the top level; 76 when issue 47's time-variable family came as the
# subpackage jaxsdp.tvp (its dozen names in the subpackage, as tfest's)
MAX_PUBLIC_TOP_LEVEL = 76
MAX_MODULE_LINES = 600


def _modules():
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        name = ".".join(parts[:-1] if is_package else parts)
        yield name, is_package, path


def _layer(module: str) -> int:
    for rank, prefixes in enumerate(LAYERS):
        if any(module == p or module.startswith(p + ".") for p in prefixes):
            return rank
    raise AssertionError(f"module {module} belongs to no layer: add it to LAYERS (and to the README)")


def _type_only(tree: ast.Module) -> set[int]:
    """`id`s of the import statements under `if TYPE_CHECKING:` (read by type checkers, never run)."""
    out = set()
    for node in ast.walk(tree):
        test = getattr(node, "test", None)
        if isinstance(node, ast.If) and getattr(test, "id", getattr(test, "attr", None)) == "TYPE_CHECKING":
            out |= {id(n) for stmt in node.body for n in ast.walk(stmt) if isinstance(n, ast.Import | ast.ImportFrom)}
    return out


def _imports(name: str, is_package: bool, path: pathlib.Path, *, type_only: bool = True):
    """(line, imported jaxsdp module, imported names) for every import of a jaxsdp module.

    Module-level and function-level imports alike; `type_only=False` leaves
    out those under `if TYPE_CHECKING:`. `from pkg import x` with `pkg.x` a
    module yields that module and no names.
    """
    package = name if is_package else name.rpartition(".")[0]
    tree = ast.parse(path.read_text())
    skip = set() if type_only else _type_only(tree)
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.split(".")[0] == "jaxsdp":
                    yield node.lineno, alias.name, ()
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "jaxsdp":
                continue
            names = tuple(a.name for a in node.names if f"{target}.{a.name}" not in MODULE_NAMES)
            for n in (a.name for a in node.names if f"{target}.{a.name}" in MODULE_NAMES):
                yield node.lineno, f"{target}.{n}", ()  # `from . import data`: a module
            if names:
                yield node.lineno, target, names


def _ancestors(module: str) -> list[str]:
    """The packages above `module`, outermost first: `a.b.c` -> [`a`, `a.b`]."""
    parts = module.split(".")
    return [".".join(parts[:i]) for i in range(1, len(parts))]


def _edges(name: str, is_package: bool, path: pathlib.Path):
    """(line, module) for each jaxsdp module whose code an import in `name` runs (see `test_no_import_circles`)."""
    initialised = set(_ancestors(name)) | ({name} if is_package else set())
    for line, target, _ in _imports(name, is_package, path):  # type-only imports too (issue 44)
        for m in _ancestors(target):
            if m not in initialised:  # a package above the import, not yet run: its `__init__` runs first
                yield line, m
        if target != name:
            yield line, target


def _cycle(graph: dict[str, dict[str, int]], start: str) -> list[str] | None:
    """A shortest import circle through `start` (`[start, ..., start]`), or None."""
    parent, queue = {}, [start]
    while queue:
        v = queue.pop(0)
        for w in sorted(graph[v]):
            if w == start:
                path = [v]
                while path[-1] != start:
                    path.append(parent[path[-1]])
                return [*reversed(path), start]
            if w not in parent:
                parent[w] = v
                queue.append(w)
    return None


MODULES = list(_modules())
MODULE_NAMES = {m[0] for m in MODULES}


@pytest.mark.parametrize("name,is_package,path", MODULES, ids=[m[0] for m in MODULES])
def test_imports_go_down_the_layers(name, is_package, path):
    if name == "jaxsdp":
        return  # the facade re-exports from every layer
    own = _layer(name)
    for line, target, names in _imports(name, is_package, path):
        where = f"{path.relative_to(PACKAGE.parent)}:{line}"
        assert target != "jaxsdp", f"{where}: imports the jaxsdp facade; import from the defining module"
        assert _layer(target) <= own, f"{where}: {name} (layer {own}) imports {target} (layer {_layer(target)})"
        private = [n for n in names if n.startswith("_") and not n.startswith("__")]
        assert not private, f"{where}: imports private names {private} of {target}; make them internal API"


def test_no_import_circles():
    """No module's imports lead back to it, function-level imports included.

    The graph's nodes are the modules, a package standing for its
    `__init__.py`. An import statement anywhere in module M (at the top,
    inside a function, or under `if TYPE_CHECKING:`: a type-only circle is a
    circle for readers and type checkers, issue 44) makes
    an edge from M to the module it names: `from .x import f` and
    `from . import x` (x a module) to `x`; `from . import f` (f defined in
    the package's `__init__`) and `from jaxsdp.plants import f` to the package.
    Importing `a.b.c` also runs the `__init__` of `a` and `a.b` first, so
    those packages are edges too, except the packages M sits in: they are
    already running when M is (importing a sibling module does not re-enter
    one's own package's `__init__`), else every subpackage whose
    `__init__` re-exports its modules would be a circle. A subpackage's
    re-exports are edges from the package to its modules, like any import.
    """
    graph = {name: {} for name, _, _ in MODULES}
    for name, is_package, path in MODULES:
        for line, target in _edges(name, is_package, path):
            graph[name].setdefault(target, line)
    circles, seen = [], set()
    for name in sorted(graph):
        if name in seen:
            continue
        cycle = _cycle(graph, name)
        if cycle:
            seen |= set(cycle)
            circles.append(" -> ".join(f"{a} (line {graph[a][b]})" for a, b in zip(cycle, cycle[1:])) + f" -> {name}")
    assert not circles, "import circles (each arrow: the importing module and the line of its import):\n" + "\n".join(
        circles
    )


def test_top_level_is_small():
    public = [n for n in dir(jaxsdp) if not n.startswith("_")]
    assert len(public) <= MAX_PUBLIC_TOP_LEVEL, public


def test_subpackages_are_reachable_from_the_top_level():
    for sub in ("plants", "data", "studies"):
        assert getattr(jaxsdp, sub).__name__ == f"jaxsdp.{sub}"
    assert jaxsdp.studies.emps.emps_study.__module__ == "jaxsdp.studies.emps._study"


@pytest.mark.parametrize("name,is_package,path", MODULES, ids=[m[0] for m in MODULES])
def test_modules_are_short(name, is_package, path):
    n = len(path.read_text().splitlines())
    assert n <= MAX_MODULE_LINES, f"{path.relative_to(PACKAGE.parent)} has {n} lines"


def test_every_export_is_defined_below_the_facade():
    # Each re-exported name resolves to an object defined in a private module.
    for n in dir(jaxsdp):
        obj = getattr(jaxsdp, n)
        mod = getattr(obj, "__module__", None)
        if n.startswith("_") or mod is None or not callable(obj):
            continue
        assert mod.startswith("jaxsdp.") and mod != "jaxsdp", (n, mod)


#: The family folders (CONTRIBUTING, "Where things go"): the modules each must hold.
FAMILIES = {
    "jaxsdp.plants.emps": ("_plant", "_model", "_preprocess", "_fits", "_idim_iv", "_sdp_stage", "_idim_sdp"),
    "jaxsdp.plants.robot": ("_serial", "_joint", "_sim", "_joint_stages", "_joint_full", "_tx40", "_tx40_link2"),
    "jaxsdp.tfest": ("_srivc", "_c2d", "_tf"),
}
#: A module whose name says it belongs to a family lives in that family's folder.
FAMILY_WORDS = {
    "emps": "jaxsdp.plants.emps",
    "robot": "jaxsdp.plants.robot",
    "tx40": "jaxsdp.plants.robot",
    "srivc": "jaxsdp.tfest",
    "rivc": "jaxsdp.tfest",
    "c2d": "jaxsdp.tfest",
}


def _study_of(module: str) -> str | None:
    """The study package (`jaxsdp.studies.<name>`) a module belongs to, None outside one."""
    parts = module.split(".")
    if len(parts) < 3 or parts[:2] != ["jaxsdp", "studies"]:
        return None
    study = ".".join(parts[:3])
    return study if (PACKAGE.parent / study.replace(".", "/") / "__init__.py").exists() else None


@pytest.mark.parametrize("name,is_package,path", MODULES, ids=[m[0] for m in MODULES])
def test_no_study_imports_another(name, is_package, path):
    """Studies stand on shared stages (plants, control, studies' own helpers), never on each other."""
    own = _study_of(name)
    if own is None:
        return
    for line, target, _ in _imports(name, is_package, path):
        other = _study_of(target)
        where = f"{path.relative_to(PACKAGE.parent)}:{line}"
        assert other in (None, own), f"{where}: the study {own} imports the study {other}; move what both need down"


def test_families_are_folders():
    for family, modules in FAMILIES.items():
        folder = PACKAGE.parent / family.replace(".", "/")
        assert (folder / "__init__.py").exists(), f"{family} is not a package"
        missing = [m for m in modules if not (folder / f"{m}.py").exists()]
        assert not missing, f"{family} lacks {missing}"
    for name, _, _ in MODULES:
        if not name.startswith(("jaxsdp.plants", "jaxsdp.control", "jaxsdp.tfest", "jaxsdp._idim")):
            continue
        leaf = name.rsplit(".", 1)[-1]
        for word, family in FAMILY_WORDS.items():
            if word in leaf and not name.startswith(family + ".") and name != family:
                raise AssertionError(f"{name}: a module of the {family} family outside its folder")


def test_the_estimators_factorise_only_through_linalg():
    # issue 44: a batched LAPACK call can deadlock XLA-CPU under vmap; QR and triangular solves of the IDIM
    # estimators go through jaxsdp._linalg (LAPACK on one problem, lax under vmap)
    banned = ("jnp.linalg.qr", "solve_triangular", "jnp.linalg.lstsq")
    bad = [
        f"{path.relative_to(PACKAGE.parent)}: {word}"
        for path in sorted((PACKAGE / "_idim").glob("*.py"))
        for word in banned
        if word in path.read_text()
    ]
    assert not bad, "factorise through jaxsdp._linalg (qr_r, qr_thin, solve_upper):\n" + "\n".join(bad)


#: What the estimation is made of: a Monte Carlo study that imports one of these runs estimation of its own.
ESTIMATION_KERNELS = {
    "sdp",
    "preprocess",
    "emps_preprocess",
    "ls_estimate",
    "linear_estimate",
    "idim_ls",
    "idim_iv",
    "idim_iv_iterate",
    "iv_iterate",
    "unrolled_estimate",
    "simulate_closed_loop",
    "simulate_emps",
    "iv_instruments",
    "emps_regression",
    "sdp_regression",
    "weighted_mass",
}


def test_the_monte_carlo_studies_hold_no_estimation_code():
    """Issue 44: a Monte Carlo study is `monte_carlo` over a pipeline after an experiment; it imports the
    pipeline, not the stages (no second copy of any stage)."""
    bad = []
    for path in sorted((PACKAGE / "studies" / "montecarlo").glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                bad += [f"{path.name}: {a.name}" for a in node.names if a.name in ESTIMATION_KERNELS]
    assert not bad, "the Monte Carlo studies import estimation stages:\n" + "\n".join(bad)


def _docstrings(tree) -> set[int]:
    """ids of the docstring constants of a module's tree (module, classes, functions)."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                out.add(id(first.value))
    return out


def test_library_messages_name_no_command_line_flags():
    """Issue 44: the library's messages serve Python users; they name arguments in backquotes (`decimate`,
    `estimator="iv"`), and the command line writes them as its options (`jaxsdp._cli.common.cli_text`). Only
    `jaxsdp/_cli/` names flags (docstrings may say which command runs what)."""
    import re

    flag = re.compile(r"(?<![\w-])--[a-z][a-z-]+")
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] == "_cli" or rel.name == "_runtime.py":  # _runtime: XLA's own flags
            continue
        tree = ast.parse(path.read_text())
        docs = _docstrings(tree)
        for node in ast.walk(tree):
            if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
                bad += [f"{rel}:{node.lineno}: {m}" for m in flag.findall(node.value)]
    assert not bad, "library messages that name command-line flags:\n" + "\n".join(bad)


def test_cli_text_writes_arguments_as_options():
    from jaxsdp._cli.common import cli_text

    flags = {"decimate": "--decimate", "estimator": "--estimator", "cutoff_hz": "--cutoff", "`a` of b": "--a"}
    assert cli_text("use a smaller decimation (`decimate`)", flags) == "use a smaller decimation (--decimate)"
    assert cli_text("IDIM-IV (`estimator=\"iv\"`) and (`estimator='iv'`)", flags) == (
        "IDIM-IV (--estimator iv) and (--estimator iv)"
    )
    assert cli_text("the cut-off `cutoff_hz`, `max_sweeps` (Python only)", flags) == (
        "the cut-off --cutoff, `max_sweeps` (Python only)"
    )
    assert cli_text("check `a` of b", flags) == "check --a"


def test_the_general_robot_path_does_not_need_the_tx40():
    """Issue 44: any robot's identification (stacked model, pipeline, one-joint stages, simulation) imports no
    TX40 module; the TX40's link 2 and its description build on the general code, not the reverse."""
    bad = []
    for path in sorted((PACKAGE / "plants" / "robot").glob("*.py")):
        if path.name.startswith("_tx40") or path.name == "__init__.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[-1].startswith("_tx40"):
                bad.append(f"{path.name}:{node.lineno}: from {'.' * node.level}{node.module} import ...")
    assert not bad, "general robot modules importing a TX40 module:\n" + "\n".join(bad)


def test_one_validation_style():
    """Issue 44: every value check is a `jaxsdp._checks.Rule` (a predicate and its message) or a function of
    `jaxsdp._checks`; no second mini-language of kind strings ("positive", "finite[]", "flag:...")."""
    kinds = {"positive", "nonnegative", "finite", "finite[]"}
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Tuple) and len(node.elts) == 3:
                last = node.elts[2]
                if isinstance(last, ast.Constant) and isinstance(last.value, str):
                    if last.value in kinds or last.value.startswith("flag:"):
                        bad.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: {last.value!r}")
            if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "parameter" and len(node.args) > 2:
                if isinstance(node.args[2], ast.Constant):
                    bad.append(f"{path.relative_to(PACKAGE)}:{node.lineno}: parameter(..., {node.args[2].value!r})")
    assert not bad, "value checks written as kind strings (use the rules of jaxsdp._checks):\n" + "\n".join(bad)


def test_no_timer_or_study_object_below_the_studies():
    """Issue 44: timing stages, progress and study objects belong to the studies and the command line; the
    estimators, plants, data and controllers below them neither time nor report (the Monte Carlo runner's own
    throughput, `jaxsdp._montecarlo`, is its result, not a study's timer)."""
    studies = _layer("jaxsdp.studies")
    banned = {"perf_counter", "StageTimer", "timed", "Progress", "WarningLines"}
    bad = []
    for name, is_package, path in MODULES:
        if name == "jaxsdp" or _layer(name) >= studies or name == "jaxsdp._montecarlo":
            continue
        tree = ast.parse(path.read_text())
        used = {n.attr for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
        used |= {n.id for n in ast.walk(tree) if isinstance(n, ast.Name)}
        used |= {a.name for n in ast.walk(tree) if isinstance(n, ast.ImportFrom) for a in n.names}
        bad += [f"{name}: {sorted(used & banned)}" for _ in [0] if used & banned]
    assert not bad, "timers or study objects below the studies layer:\n" + "\n".join(bad)
