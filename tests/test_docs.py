"""The documentation: examples run, every public name has its own readable docstring, `__all__` is exact.

- Every module under `jaxsdp` has its doctests run (one case per module;
  a module without examples is skipped, with that reason).
- The public packages are found, not listed: `jaxsdp` and every subpackage
  whose dotted path has no `_`-prefixed component (`jaxsdp.plants`,
  `jaxsdp.studies.montecarlo`, ...).
- Every name a public package exports carries its own docstring (not
  inherited, more than one line, never "see the module docstring"), its maths
  between `$...$` or `$$...$$` (rendered on the site by pymdownx.arithmatex
  and MathJax) and readable in help(): TeX symbols (`\\theta`, `\\sum`,
  `\\hat`, `\\le`, ...) but no markup (`\\frac`, `\\mathrm`, `\\text`,
  `\\left`, environments, spacing) and no TeX outside the dollars (issue 13
  kept raw LaTeX out of help(); issue 43 renders the formulas on the API
  pages); every exported function shows an `Example:` in doctest format.
- The `__all__` of each public package lists exactly its public names: every
  name it imports or defines without a leading underscore, and no other.
"""

import doctest
import importlib
import inspect
import pkgutil
import re
import types

import pytest

import jaxsdp

MODULES = ["jaxsdp"] + sorted(m.name for m in pkgutil.walk_packages(jaxsdp.__path__, "jaxsdp."))
# The public packages: `jaxsdp` and every subpackage with no `_`-prefixed component in its dotted path.
PACKAGES = ["jaxsdp"] + sorted(
    m.name
    for m in pkgutil.walk_packages(jaxsdp.__path__, "jaxsdp.")
    if m.ispkg and not any(part.startswith("_") for part in m.name.split("."))
)
OPTIONS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE

# Maths in a docstring: `$$...$$` (display, may span lines) or `$...$` (inline, one line).
MATH = re.compile(r"\$\$.+?\$\$|\$[^$\n]+\$", flags=re.S)
# A TeX command (or `\|`): allowed only inside the maths.
TEX_COMMAND = re.compile(r"\\[A-Za-z]+|\\\|")
# TeX markup, unreadable in help(): not even inside the maths (symbols such as \theta, \sum, \hat, \le are fine).
TEX_MARKUP = re.compile(
    r"\\(frac|tfrac|dfrac|mathrm|mathbf|mathtt|mathcal|mathbb|operatorname|text\w*|left|right|begin|end"
    r"|displaystyle|[bB]igg?[lr]?)\b|\\[,;:!]"
)


@pytest.mark.docs  # the API pages' examples: .ci/run's docs step (`-m docs`)
@pytest.mark.parametrize("name", MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    runner = doctest.DocTestRunner(optionflags=OPTIONS)
    report = []
    for test in doctest.DocTestFinder(exclude_empty=True).find(module, name):
        runner.run(test, out=report.append)
    failed, tried = runner.summarize(verbose=False)
    if tried == 0:
        pytest.skip("module without doctest examples (its public names are checked by test_public_docstring)")
    assert failed == 0, f"{failed} of {tried} doctest examples of {name} failed:\n" + "".join(report)


def _public_names(package: str) -> list[str]:
    """`__all__`, or (for a package that does not declare it) its public non-module names."""
    module = importlib.import_module(package)
    if hasattr(module, "__all__"):
        return list(module.__all__)
    return [n for n in dir(module) if not n.startswith("_") and not isinstance(getattr(module, n), types.ModuleType)]


def _exports():
    for package in PACKAGES:
        module = importlib.import_module(package)
        for name in _public_names(package):
            obj = getattr(module, name, None)
            if isinstance(obj, types.ModuleType):
                continue
            yield f"{package}.{name}", obj


EXPORTS = sorted(_exports())


def _own_doc(obj) -> str | None:
    if isinstance(obj, type):
        return obj.__dict__.get("__doc__")  # a class's own, never a base class's
    return getattr(obj, "__doc__", None)


def _is_function(obj) -> bool:
    return callable(obj) and not isinstance(obj, type)


def _is_constant(obj) -> bool:
    return not callable(obj)  # dicts, tuples, numbers: documented where defined, no docstring of their own


@pytest.mark.parametrize("qualname,obj", EXPORTS, ids=[q for q, _ in EXPORTS])
def test_public_docstring(qualname, obj):
    if _is_constant(obj):
        pytest.skip("a constant: no docstring of its own (documented where it is defined)")
    doc = _own_doc(obj)
    assert doc and doc.strip(), f"{qualname} has no docstring of its own"
    doc = inspect.cleandoc(doc)
    assert len(doc.splitlines()) > 1, f"{qualname}: a one-line docstring ({doc!r}); state the model, units, example"
    assert "module docstring" not in doc, f"{qualname} refers to the module docstring; document it here"
    prose = "\n".join(line for line in doc.splitlines() if not line.lstrip().startswith((">>>", "...")))
    maths = [m.group(0) for m in MATH.finditer(prose)]
    raw = sorted(set(TEX_COMMAND.findall(MATH.sub("", prose))))
    assert not raw, f"{qualname}: TeX outside the maths {raw}; put formulas between $...$ (or $$...$$)"
    markup = sorted({m.group(0) for math in maths for m in TEX_MARKUP.finditer(math)})
    assert not markup, f"{qualname}: TeX markup {markup}; keep the maths readable in help() (symbols only)"
    if _is_function(obj):
        assert "Example" in doc and ">>>" in doc, f"{qualname}: no `Example:` with `>>>` lines"


@pytest.mark.parametrize("package", PACKAGES)
def test_all_lists_the_exports(package):
    module = importlib.import_module(package)
    assert hasattr(module, "__all__"), f"{package} has no __all__"
    declared = list(module.__all__)
    assert len(declared) == len(set(declared)), f"{package}.__all__ has duplicates"
    public = {n for n in vars(module) if not n.startswith("_")}
    missing = sorted(public - set(declared))
    extra = sorted(set(declared) - public)
    assert not missing and not extra, f"{package}.__all__: missing {missing}, extra (not defined) {extra}"
