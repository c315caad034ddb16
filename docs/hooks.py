"""mkdocs hooks of the jaxsdp site: the version in the title, Google "Example:" sections, figures made at build.

- `on_config`: the site name carries the documented version (`jaxsdp.__version__`);
  griffe's Google parser learns the singular "Example:" heading jaxsdp's
  docstrings use (so their `>>>` blocks render as code, not as markdown).
- `on_page_markdown`: `{{ version }}` in a page is replaced by that version,
  `{{ gpu_table }}` by the GPU table read from the saved benchmark logs
  (`benchmarks/results/gpu/`), `{{ run CASE /json/path FORMAT }}` and
  `{{ stdout CASE }}` by the values of the study runs' snapshot
  (`benchmarks/results/studies/`), `{{ bench ... }}` and
  `{{ bench-table scaling TASK }}` by the saved CPU benchmark results
  (`benchmarks/results/cpu/`), all by `benchmarks/_results.py`.
- `on_pre_build`, first and always (plotting only, cheap): the figures of
  "How the cost grows" on the performance page, drawn into
  `docs/generated/scaling/` from the saved `benchmarks/results/cpu/scaling.json`
  by `benchmarks/scaling.py`'s `figures` (the benchmark itself never runs
  at build time).
- `on_pre_build`: the study guides' figures are drawn now, into
  `docs/generated/` (git-ignored), never committed: the EMPS study's from the
  main job's run on the built-in simulated plant, the control study's from
  its run on the built-in data (without the gradient tuning), the TX40
  study's from its example study (simulated data, the one its docstrings
  use), the robot study's from the robot the robots guide discusses: the
  real TX40 logs when the shared data folder is there (`JAXSDP_SHARED`, else
  `../shared` beside the checkout), else the simulated six-joint TX40
  (`tx40_all_joints_data`), each named in the figures' titles.
  `JAXSDP_DOCS_FIGURES=0` skips redrawing when the files are already there
  (a quick local preview). The guides listed in `EXECUTED_GUIDES` have their
  ```python blocks run in order (`run_guide_code`), and every `fig_NAME`
  they leave is saved as `generated/<guide>/fig_NAME.png` (the page's
  figures are its code's; `tests/test_tvp.py` runs the same blocks).
"""

import os
import pathlib

GENERATED = pathlib.Path(__file__).resolve().parent / "generated"
#: Guides whose code blocks are run at build time (their figures are the code's).
EXECUTED_GUIDES = ("tvp",)


def run_guide_code(guide: str) -> dict:
    """Run the ```python blocks of docs/guides/<guide>.md in order in one namespace (matplotlib's Agg backend)."""
    import re

    import matplotlib

    matplotlib.use("Agg")
    text = (pathlib.Path(__file__).resolve().parent / "guides" / f"{guide}.md").read_text()
    namespace = {"__name__": f"guide_{guide}"}
    for block in re.findall(r"^```python\n(.*?)^```", text, flags=re.S | re.M):
        exec(compile(block, f"docs/guides/{guide}.md", "exec"), namespace)
    return namespace


def on_config(config):
    import jaxsdp

    config["site_name"] = f"jaxsdp {jaxsdp.__version__}"
    config["extra"]["version"] = jaxsdp.__version__
    try:
        from griffe._internal.docstrings.google import _section_kind
        from griffe._internal.enumerations import DocstringSectionKind

        _section_kind.setdefault("example", DocstringSectionKind.examples)
    except ImportError:  # another griffe layout: "Example:" then renders as an admonition
        pass
    return config


def on_page_markdown(markdown, page, config, files):
    """`{{ version }}` in a page becomes the documented version, `{{ gpu_table }}` the measured GPU table."""
    markdown = markdown.replace("{{ version }}", config["extra"]["version"])
    if "{{ gpu_table }}" in markdown:
        markdown = markdown.replace("{{ gpu_table }}", _benchmark_results().gpu_table())
    if any(
        tag in markdown for tag in ("{{ run ", "{{ stdout ", "{{ stderr ", "{{ bench ", "{{ bench-table ", "{{ calc ")
    ):
        markdown = _benchmark_results().render_quotes(markdown)
    return markdown


def _benchmark_module(name: str):
    """`benchmarks/NAME.py` as a module, without putting `benchmarks/` on `sys.path` (its scripts' names, e.g.
    `control`, would shadow packages)."""
    import importlib.util

    path = pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / f"{name}.py"
    spec = importlib.util.spec_from_file_location(f"jaxsdp_benchmark_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _benchmark_results():
    return _benchmark_module("_results")


def scaling_figures() -> dict:
    """The performance page's scaling figures, from the saved run (`benchmarks/results/cpu/scaling.json`)."""
    import json

    saved = pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / "results" / "cpu" / "scaling.json"
    return _benchmark_module("scaling").figures(json.loads(saved.read_text()))


def _save(folder, figures):
    folder.mkdir(parents=True, exist_ok=True)
    for name, fig in figures.items():
        fig.savefig(folder / f"{name}.png", dpi=90)


def on_pre_build(config):
    _save(GENERATED / "scaling", scaling_figures())
    if os.environ.get("JAXSDP_DOCS_FIGURES") == "0" and GENERATED.exists():
        return
    import jaxsdp  # noqa: F401  (x64 and the CPU options first)
    from jaxsdp.studies import control, emps, robot, tx40

    _save(GENERATED / "emps", emps.figures(emps.emps_study()))
    _save(
        GENERATED / "control",
        control.figures(control.control_study(settings=control.ControlSettings(tune_iterations=0))),
    )
    _save(GENERATED / "tx40", tx40.figures(tx40.example_study()))
    _save(GENERATED / "robot", robot.figures(_tx40_robot_study()))
    for guide in EXECUTED_GUIDES:
        namespace = run_guide_code(guide)
        figures = {k: getattr(v, "figure", v) for k, v in namespace.items() if k.startswith("fig_")}
        _save(GENERATED / guide, figures)


def _tx40_robot_study():
    """`jaxsdp robot --drives tx40` on the real TX40 logs when the shared folder has them, else on the simulated
    six-joint TX40 (its logs already reduced by the gear ratios: drives with the offsets and the coupling only)."""
    from jaxsdp.data import Drives, load_joint_logs, tx40_all_joints_data
    from jaxsdp.data._drives import BUILTIN
    from jaxsdp.plants import SerialRobot
    from jaxsdp.plants.robot import tx40_robot
    from jaxsdp.studies import robot

    root = pathlib.Path(__file__).resolve().parents[1]
    shared = pathlib.Path(os.environ.get("JAXSDP_SHARED", root / ".." / "shared")) / "data" / "tx40"
    files = [shared / n for n in ("pos_read_data.csv", "curr_data.csv", "tx40_mdh_modified.urdf")]
    if all(f.is_file() for f in files):
        logs = load_joint_logs(files[0], files[1], dt=2e-4)
        arm = SerialRobot.from_urdf(files[2])
        # the figures need the fit and the SDP curves only: no physical estimate, no cross-validation (minutes of
        # the suite's site build)
        return robot.robot_study(
            logs, robot=arm, drives=Drives.builtin("tx40"), source="real TX40 logs", physical=False, folds=0
        )
    logs = tx40_all_joints_data()[0]
    drives = Drives([1.0] * 6, offsets=BUILTIN["tx40"]["offsets"], coupling=BUILTIN["tx40"]["coupling"])
    return robot.robot_study(
        logs, robot=tx40_robot(), drives=drives, source="simulated six-joint TX40", physical=False, folds=0
    )
