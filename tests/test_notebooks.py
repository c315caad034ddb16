"""The notebooks in notebooks/ (and its subfolders, e.g. the cookbook): committed without outputs, each in the site's
navigation.

They are executed from top to bottom, in their small setting
(`JAXSDP_NOTEBOOK_SMALL=1`), all in one kernel; the site's strict build in the
suite renders them without running them again.
"""

import os
import pathlib

import pytest

pytestmark = pytest.mark.docs  # .ci/run's docs step (`-m docs`)

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


#: Run in the shared kernel before each notebook: a fresh namespace, 64-bit mode off and no figures, as in a new
#: kernel, and the notebook's folder as the working directory (as when opened there).
_FRESH = """%reset -f
import os as _os, jax as _jax, matplotlib.pyplot as _plt
_jax.config.update("jax_enable_x64", False)
_plt.close("all")
_os.chdir({folder!r})
del _os, _jax, _plt
"""


def test_notebooks_run_top_to_bottom_in_their_small_setting():
    """Every notebook executed from top to bottom (`JAXSDP_NOTEBOOK_SMALL=1`), any error failing the test.

    All in one IPython kernel, each notebook in a fresh namespace (`_FRESH`): one kernel start and one
    `import jaxsdp` for the twelve, and the programs they share traced and compiled once (measured 2026-11-28:
    about 230 s of separate kernels). The site's strict build in the suite renders the notebooks without running
    them again (`tests/test_docs_site.py`); the published site runs them (mkdocs-jupyter, `execute: true`).
    """
    nbformat = pytest.importorskip("nbformat", reason="notebook tests need the test extra (nbmake)")
    nbclient = pytest.importorskip("nbclient", reason="notebook tests need the test extra (nbmake)")
    from jupyter_client.manager import KernelManager

    km = KernelManager(kernel_name="python3")
    km.start_kernel(env=dict(os.environ, JAXSDP_NOTEBOOK_SMALL="1"), cwd=str(ROOT))
    try:
        for path in NOTEBOOKS:
            nb = nbformat.read(path, as_version=4)
            nb.cells.insert(0, nbformat.v4.new_code_cell(_FRESH.format(folder=str(path.parent))))
            client = nbclient.NotebookClient(nb, km=km, timeout=900, allow_errors=False)
            try:
                client.execute()
            except nbclient.exceptions.CellExecutionError as err:
                pytest.fail(f"{path.relative_to(ROOT)}: {err}"[:6000])
    finally:
        km.shutdown_kernel(now=True)
