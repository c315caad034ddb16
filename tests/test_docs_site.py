"""The documentation site: every public name in the API reference, README links to its pages, a strict build.

The strict build (`mkdocs build --strict`: broken links, missing references
and docstring warnings fail it) draws the guides' figures (`docs/hooks.py`)
and renders the notebooks without executing them (`JAXSDP_DOCS_EXECUTE=false`):
`tests/test_notebooks.py` runs them, all in one kernel, where the build would
start a kernel for each.
"""

import importlib
import os
import pathlib
import pkgutil
import re
import subprocess
import sys

import pytest

import jaxsdp

pytestmark = pytest.mark.docs  # .ci/run's docs step (`-m docs`)

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


def public_modules():
    names = ["jaxsdp"]
    for info in pkgutil.walk_packages(jaxsdp.__path__, "jaxsdp."):
        if info.ispkg and not any(part.startswith("_") for part in info.name.split(".")[1:]):
            names.append(info.name)
    return names


def api_text():
    return "\n".join(p.read_text() for p in sorted((DOCS / "api").glob("*.md")))


def test_every_public_name_is_in_the_api_reference():
    text = api_text()
    entries = set(re.findall(r"^::: (\S+)$", text, flags=re.M))
    listed = set(re.findall(r"^- `(\S+)`:", text, flags=re.M))  # re-exports and subpackages: a linked line
    missing = []
    for mod in public_modules():
        for name in importlib.import_module(mod).__all__:
            if f"{mod}.{name}" not in entries | listed:
                missing.append(f"::: {mod}.{name}")
    assert not missing, "add to docs/api/<module>.md:\n" + "\n".join(missing)
    for entry in entries:  # and nothing stale: every entry names a public object
        mod, _, name = entry.rpartition(".")
        assert name in importlib.import_module(mod).__all__, f"docs/api: {entry} is not public"


def test_readme_points_to_the_site_pages():
    readme = (ROOT / "README.md").read_text()
    links = re.findall(r"\]\((docs/[^)#]+)(?:#[^)]*)?\)", readme)
    assert len(links) >= 8, links  # the README points to the site for everything past the quick start
    for link in links:
        assert (ROOT / link).is_file(), f"README links to {link}, which is not a file under docs/"


def test_nav_pages_exist():
    nav = re.findall(r":\s*((?:[\w.-]+/)*[\w.-]+\.(?:md|ipynb))\s*$", (ROOT / "mkdocs.yml").read_text(), flags=re.M)
    assert len(nav) > 20
    for page in nav:
        assert (DOCS / page).is_file(), page


def test_site_builds_in_strict_mode(tmp_path):
    pytest.importorskip("mkdocs", reason="the site build needs the docs tools (the test extra installs them)")
    env = dict(os.environ, JAXSDP_DOCS_EXECUTE="false", NO_MKDOCS_2_WARNING="1")
    site = tmp_path / "site"
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=1500,
    )
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, log[-6000:]
    assert (site / "index.html").is_file() and (site / "api" / "tfest.html").is_file()
    index = (site / "index.html").read_text()
    assert f"jaxsdp {jaxsdp.__version__}" in index  # the site states the version it documents
    nb = (site / "notebooks" / "riv_family.html").read_text()
    assert "output_png" in nb or "image/png" in nb  # the notebooks are rendered with their outputs
    # every figure on the site is an image: a figure rendered as its text repr fails, naming the page
    as_text = [str(p.relative_to(site)) for p in site.rglob("*.html") if "&lt;Figure size" in p.read_text()]
    assert not as_text, f"figures rendered as text (add %matplotlib inline or return an image): {as_text}"
    for fig in ("emps/fig3_sdp_mass.png", "control/fig14_step_responses.png", "tx40/fig7_shapes.png"):
        assert (site / "generated" / fig).is_file(), fig
    # every number quoted from a run is filled in (the contributing page shows the syntax itself)
    left = [
        str(p.relative_to(site))
        for p in site.rglob("*.html")
        if p.name != "contributing.html" and re.search(r"\{\{ (run|bench|stdout|stderr|gpu_table)\b", p.read_text())
    ]
    assert not left, f"quotes the docs hook did not fill (docs/hooks.py, benchmarks/_results.py): {left}"
    assert "Measured on one NVIDIA" in (site / "performance.html").read_text()  # the GPU table, from the logs


def test_version_flag_states_the_documented_version():
    out = subprocess.run([sys.executable, "-m", "jaxsdp", "--version"], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0 and out.stdout.strip() == f"jaxsdp {jaxsdp.__version__}", out
