"""The documentation refers only to what exists (issue 43): no page defers to README content (the README is the
entry page; the guides are the reference), a 'see "X" below/above' names a heading of the same page, and no page
holds a machine's absolute path. Links and anchors are checked by the strict site build (test_docs_site.py)."""

import json
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md", ROOT / "CONTRIBUTING.md"]
NOTEBOOKS = [
    p
    for folder in (ROOT / "docs" / "notebooks", ROOT / "notebooks")
    for p in sorted(folder.rglob("*.ipynb"))  # with the subfolders (the cookbook: notebooks/cookbook/)
    if ".ipynb_checkpoints" not in p.parts
]
#: "README" as a source of content; a data folder's README.md file is a file name, not a reference.
README_REFERENCE = re.compile(r"\bREADME\b(?!\.md)")
#: An absolute path of a machine (a user's home, a work or temporary folder).
MACHINE_PATH = re.compile(r"(?<![\w.~-])/(?:work|tmp|root|home|Users|mnt|check)/[\w.-]+")
SEE = re.compile(r"""see ["“]([^"”]+)["”] (?:below|above)""")


def _rel(p: pathlib.Path) -> str:
    return str(p.relative_to(ROOT))


#: What a page may cite of the README: its two set-up commands.
README_COMMANDS = ("README's test command", "README's quick start")


def _lines(page):
    yield from enumerate(page.read_text().splitlines(), start=1)


@pytest.mark.parametrize("page", [p for p in PAGES if p.name != "README.md"], ids=_rel)
def test_no_page_defers_to_the_readme(page):
    bad = [
        f"{_rel(page)}:{k}: {line.strip()}"
        for k, line in _lines(page)
        if README_REFERENCE.search(line) and not any(c in line for c in README_COMMANDS)
    ]
    assert not bad, "pages that point to README content (move the content to the page or link a page):\n" + "\n".join(
        bad
    )


@pytest.mark.parametrize("page", PAGES, ids=_rel)
def test_see_below_names_a_heading_of_the_page(page):
    text = page.read_text()
    headings = {h.strip().strip("#").strip().lower() for h in re.findall(r"^#+ .*$", text, flags=re.M)}
    bad = [m.group(1) for m in SEE.finditer(text) if m.group(1).strip().lower() not in headings]
    assert not bad, f"{_rel(page)} refers to sections it does not have: {bad}"


@pytest.mark.parametrize("page", PAGES + NOTEBOOKS, ids=_rel)
def test_no_machine_paths(page):
    if page.suffix == ".ipynb":
        cells = json.loads(page.read_text())["cells"]
        text = "\n".join(
            "".join(c.get("source", [])) + "".join("".join(o.get("text", [])) for o in c.get("outputs", []))
            for c in cells
        )
    else:
        text = page.read_text()
    found = sorted(set(MACHINE_PATH.findall(text)))
    assert not found, f"{_rel(page)} holds a machine's absolute path: {found}; use a path relative to the checkout"


# --------------------------------------------------------------------------- #
# Maths (issue 43, item 3): the concepts page and the guides write their formulas in LaTeX, which
# pymdownx.arithmatex hands to MathJax; the API pages' docstrings too (their rules: tests/test_docs.py).
# --------------------------------------------------------------------------- #

MATH_PAGES = [ROOT / "docs" / "concepts.md"] + sorted((ROOT / "docs" / "guides").glob("*.md"))
#: A formula in plain-text maths: a relation (` = `, ` <= `, ` >= `, ` ~ `) between plain-text maths tokens
#: (a power `^`, `sum`, `theta`, `sigma`, `sqrt(`, a norm `||`, `dq`/`ddq`, `pi`, `eta`, `xi`, `eps`, `tau`).
PLAIN_RELATION = re.compile(r"\s(=|<=|>=|~)\s")
PLAIN_TOKEN = re.compile(
    r"\^|\bsum_?|\btheta|\bsigma|\bsqrt\(|\|\||\bddq\b|\bdq\b|\bpi\b|\beta\b|\bxi\b|\beps\b|\btau\b"
)
FENCE = re.compile(r"^```.*?^```", flags=re.M | re.S)
INLINE_CODE = re.compile(r"`[^`\n]*`")
DISPLAY_MATH = re.compile(r"^\s*\$\$\s*$(.*?)^\s*\$\$\s*$", flags=re.M | re.S)
INLINE_MATH = re.compile(r"\$[^$\n]+\$")


@pytest.mark.parametrize("page", MATH_PAGES, ids=_rel)
def test_formulas_are_latex(page):
    """No formula left as plain text in inline code (`y = X theta + e` was the old style), and every `$` pairs
    up: a display block's `$$` lines, or an inline `$...$` on one line (a lone `$` would swallow text)."""
    text = FENCE.sub("", page.read_text())  # commands and Python keep their own notation
    plain = [c for c in INLINE_CODE.findall(text) if PLAIN_RELATION.search(c) and PLAIN_TOKEN.search(c)]
    assert not plain, f"{_rel(page)}: formulas in plain text, write them as $...$ (LaTeX): {plain}"
    prose = INLINE_MATH.sub("", DISPLAY_MATH.sub("", INLINE_CODE.sub("", text)))
    lone = [line.strip() for line in prose.splitlines() if "$" in line]
    assert not lone, f"{_rel(page)}: a `$` without its pair (maths is $...$ on one line, or $$ lines): {lone}"


def test_site_renders_maths():
    """mkdocs.yml turns `$...$`/`$$...$$` into arithmatex elements (generic mode) and loads MathJax 3 with the
    configuration that typesets exactly those elements; the concepts page holds display maths."""
    config = (ROOT / "mkdocs.yml").read_text()
    assert re.search(r"^  - pymdownx\.arithmatex:.*\n\s+generic: true\s*$", config, flags=re.M), "arithmatex, generic"
    scripts = re.search(r"^extra_javascript:.*\n((?:  - .*\n)+)", config, flags=re.M)
    assert scripts, "mkdocs.yml has no extra_javascript"
    listed = re.findall(r"^  - (\S+)", scripts.group(1), flags=re.M)
    assert listed[0] == "javascripts/mathjax.js", listed  # the configuration before the library
    assert any(re.fullmatch(r"https://\S+/mathjax@3/es5/tex-mml-chtml\.js", s) for s in listed), listed
    mathjax = (ROOT / "docs" / "javascripts" / "mathjax.js").read_text()
    assert 'processHtmlClass: "arithmatex"' in mathjax and "document$.subscribe" in mathjax
    concepts = (ROOT / "docs" / "concepts.md").read_text()
    assert len(DISPLAY_MATH.findall(concepts)) >= 10, "the concepts page writes its equations as display maths"
