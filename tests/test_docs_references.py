"""The documentation refers only to what exists (issue 43): no page defers to README content (the README is the
entry page; the guides are the reference), a 'see "X" below/above' names a heading of the same page, and no page
holds a machine's absolute path. Links and anchors are checked by the strict site build (test_docs_site.py)."""

import json
import pathlib
import re

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md")) + [ROOT / "README.md", ROOT / "CONTRIBUTING.md"]
NOTEBOOKS = sorted((ROOT / "docs" / "notebooks").glob("*.ipynb")) + sorted((ROOT / "notebooks").glob("*.ipynb"))
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
