"""The notebooks in notebooks/ (and its subfolders, e.g. the cookbook): committed without outputs, each in the site's
navigation.

They are executed from top to bottom, in their small setting
(`JAXSDP_NOTEBOOK_SMALL=1`), by the documentation site's strict build
(`tests/test_docs_site.py::test_site_builds_in_strict_mode`: mkdocs-jupyter
with `allow_errors: false`), which renders them with their outputs: running
them here as well would cost the suite the same minutes twice.
"""

import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted(p for p in (ROOT / "notebooks").rglob("*.ipynb") if ".ipynb_checkpoints" not in p.parts)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.relative_to(ROOT / "notebooks").as_posix() for p in NOTEBOOKS])
def test_notebook_is_clean_and_in_the_site(path):
    nbformat = pytest.importorskip("nbformat", reason="notebook tests need the test extra (nbmake)")
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert code, "a notebook without code"
    assert all(not c.get("outputs") and c.get("execution_count") is None for c in code), "commit without outputs"
    page = path.relative_to(ROOT).as_posix()  # e.g. notebooks/cookbook/axis_from_csv.ipynb, docs/notebooks on the site
    assert page in (ROOT / "mkdocs.yml").read_text(), f"list {page} in mkdocs.yml's nav"
