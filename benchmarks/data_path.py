"""The path the data takes through a study: files visited, returns to a file already visited (issue 44).

Runs the study once to compile, then again under `sys.setprofile`, recording every Python call into a
`jaxsdp` module with its caller's file. Three counts, each for the whole study and for its identification
stages only (the calls under the record, the checks, the preprocessing, the fits, IDIM-IV and the decimation
and simulation checks; not the report):

- (a) the sequence of files of all calls, consecutive repeats collapsed: files = distinct files, returns =
  entries naming a file already seen;
- (b) the same, keeping only calls from another file (a walk over the file graph);
- (c) back edges: the distinct caller-file -> callee-file edges whose target was first visited before the
  source (a step back up the first-visit order), each counted once however often it is taken; the most
  useful count, since each one names a coupling (e.g. a study timer passed down into the plants layer).

Each count is also given beyond the foundation modules (`FOUNDATION`: `_checks.py`, `_runtime.py`), the leaves
every layer calls (a value check, the float64 entry wrapper): a call into one is no step along the data's path.

Before and after a refactoring, compare the three with the same script:

    python benchmarks/data_path.py [--study emps|emps-iv|robot] [--edges] [--json PATH]
"""

import argparse
import collections
import inspect
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

import jax  # noqa: E402
from _record import Recorder  # noqa: E402

import jaxsdp  # noqa: E402, I001  (before JAX's backend starts)

PACKAGE = str(pathlib.Path(jaxsdp.__file__).resolve().parent) + "/"
#: The functions whose calls make the identification stages (not the report, the findings or the summary).
STAGES = {
    "emps_builtin_data",
    "load_record",
    "check_emps_data",
    "emps_preprocess",
    "emps_fits",
    "emps_idim_iv",
    "estimate",  # EMPSPipeline.estimate (issue 44: the study's estimation as one pure Module)
    "fits_from",
    "decimation_check",
    "simulation_check",
    # the robot study's: the stacked model and IDIM-LS, each joint's residual SDP
    "robot_model",
    "robot_idim_ls",
    "robot_residual_sdp",
}
#: The studies traced; "robot" is the two-joint example robot's study (`jaxsdp.studies.robot.example_study`),
#: whose arguments are the same at every commit since the robot study exists.
STUDIES = ("emps", "emps-iv", "robot")


def _run(study: str):
    """A function running `study` once (the options made here, so that an older checkout's API serves too)."""
    if study == "robot":  # robot_study on the example's logs and arm (the example itself is cached)
        import jaxsdp.studies.robot._study as module
        from jaxsdp.studies.robot import example_study

        study_fn, args = module.robot_study, {}
        module.robot_study = lambda logs, **kw: args.update(logs=logs, **kw) or study_fn(logs, **kw)
        try:
            example_study.__wrapped__()
        finally:
            module.robot_study = study_fn
        return lambda: study_fn(**args)
    from jaxsdp.studies.emps import emps_study

    if study == "emps-iv":
        if "iv" in inspect.signature(emps_study).parameters:
            return lambda: emps_study(iv=jaxsdp.IDIMIV(), check_decimation=False)
        return lambda: emps_study(estimator="iv", check_decimation=False)  # before the option Modules
    return emps_study


def trace(study: str):
    """(file, caller file or None, function, stage or None) of every call into jaxsdp during one warm run."""
    run = _run(study)
    run()  # compile first: the traced run is what a user's second call does
    events, stack = [], []

    def profile(frame, event, arg):
        if event == "call":
            f = frame.f_code.co_filename
            caller = frame.f_back.f_code.co_filename if frame.f_back else ""
            if f.startswith(PACKAGE):
                # a stage's own entry counts in it too
                stage = next((s for s in (*stack, frame.f_code.co_name) if s in STAGES), None)
                inside = caller[len(PACKAGE) :] if caller.startswith(PACKAGE) else None
                events.append((f[len(PACKAGE) :], inside, frame.f_code.co_name, stage))
            stack.append(frame.f_code.co_name)
        elif event == "return" and stack:
            stack.pop()

    sys.setprofile(profile)
    try:
        run()
    finally:
        sys.setprofile(None)
    return events


def walk(files):
    """(distinct files, returns, collapsed sequence) of a sequence of files."""
    out, seen, returns = [], set(), 0
    for f in files:
        if out and out[-1] == f:
            continue
        returns += f in seen
        seen.add(f)
        out.append(f)
    return len(seen), returns, out


def back_edges(events):
    """The distinct caller -> callee file edges pointing back up the first-visit order, and all edges."""
    order = {}
    for f, _, _, _ in events:
        order.setdefault(f, len(order))
    edges = {}
    for f, caller, name, _ in events:
        if caller is not None and caller != f:
            edges.setdefault((caller, f), name)
    back = {e: n for e, n in edges.items() if order[e[1]] < order[e[0]]}
    return back, edges


#: The foundation modules: leaves that every layer calls (value checks, the float64 entry wrapper). A call into
#: one is no step along the data's path, so the counts are also given without them (`*_beyond_foundation`).
FOUNDATION = ("_checks.py", "_runtime.py")


def beyond_foundation(events):
    """`events` without the calls into the foundation modules; a call made from one has no caller file."""
    return [(f, None if c in FOUNDATION else c, n, s) for f, c, n, s in events if f not in FOUNDATION]


def counts(events):
    files, calls, _ = walk([f for f, _, _, _ in events])
    _, crossing, _ = walk([f for f, c, _, _ in events if c != f])
    back, edges = back_edges(events)
    app = beyond_foundation(events)
    files_app, calls_app, _ = walk([f for f, _, _, _ in app])
    back_app, edges_app = back_edges(app)
    return dict(
        files=files,
        returns_all_calls=calls,
        returns_file_crossing=crossing,
        back_edges=len(back),
        edges=len(edges),
        files_beyond_foundation=files_app,
        returns_beyond_foundation=calls_app,
        back_edges_beyond_foundation=len(back_app),
        edges_beyond_foundation=len(edges_app),
    ), back


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", choices=sorted(STUDIES), default="emps")
    ap.add_argument("--edges", action="store_true", help="list the back edges (caller file -> callee file)")
    ap.add_argument("--json", type=pathlib.Path, default=None, help="also write the counts here")
    args = ap.parse_args()
    rec = Recorder("benchmarks/data_path.py", args.json, study=args.study)
    with jax.enable_x64(True):
        events = trace(args.study)
    for label, part in (("whole study", events), ("identification stages", [e for e in events if e[3]])):
        c, back = counts(part)
        print(
            f"{label:22s}: {c['files']} files; returns (a) {c['returns_all_calls']}, (b) "
            f"{c['returns_file_crossing']}; back edges (c) {c['back_edges']} of {c['edges']} edges"
        )
        print(
            f"{'':22s}  beyond the foundation modules ({', '.join(FOUNDATION)}): {c['files_beyond_foundation']} "
            f"files; returns (a) {c['returns_beyond_foundation']}; back edges (c) "
            f"{c['back_edges_beyond_foundation']} of {c['edges_beyond_foundation']} edges"
        )
        rec.add(key="stages" if label.startswith("identification") else "study", **c)
        if args.edges:
            for (src, dst), name in sorted(back.items()):
                print(f"    {src} -> {dst} ({name})")
    first = collections.OrderedDict()
    for f, _, name, stage in events:
        if stage:
            first.setdefault(f, name)
    print("files of the identification stages, first-visit order: " + ", ".join(first))


if __name__ == "__main__":
    main()
