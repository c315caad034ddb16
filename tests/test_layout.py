"""The package layout: layers import only downwards, a small top level, short modules.

The layers, lowest first (see README, "Architecture"): foundations, the
estimation core (Kalman kernels, then SDP), signal processing,
identification, plants, data, control, studies, command line. A module may
import from its own layer and the layers below it, never from above, and
never from the `jaxsdp` facade (`jaxsdp/__init__.py`), which only re-exports.
"""

import ast
import pathlib

import pytest

import jaxsdp

PACKAGE = pathlib.Path(jaxsdp.__file__).parent
LAYERS = (
    ("jaxsdp._version", "jaxsdp._runtime", "jaxsdp._checks", "jaxsdp._io", "jaxsdp._scan", "jaxsdp._montecarlo"),
    ("jaxsdp._kalman",),
    ("jaxsdp._sdp",),
    ("jaxsdp._signal",),
    ("jaxsdp._idim",),
    ("jaxsdp.plants",),
    ("jaxsdp.data",),
    ("jaxsdp.control",),  # controllers and their design (the control issue)
    ("jaxsdp.studies",),
    ("jaxsdp._cli", "jaxsdp.__main__"),
)
MAX_PUBLIC_TOP_LEVEL = 60
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


def _imports(name: str, is_package: bool, path: pathlib.Path):
    """(line, imported jaxsdp module, imported names) for every import of a jaxsdp module."""
    package = name if is_package else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text())):
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
            names = tuple(a.name for a in node.names)
            if node.module is None:  # `from . import data`: the names are modules
                for n in names:
                    yield node.lineno, f"{target}.{n}", ()
            else:
                yield node.lineno, target, names


MODULES = list(_modules())


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
