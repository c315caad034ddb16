"""Numbers the docs quote from runs come from runs (issue 43).

The pages quote study results as `{{ run CASE /json/path FORMAT }}` (and printed output as
`{{ stdout CASE }}`), replaced at build time by the values of the committed snapshot in
`benchmarks/results/studies/` (`python benchmarks/study_snapshot.py run benchmarks/results/studies`).
These tests check that every quote resolves, and that each quoted number equals a fresh run's at the page's
precision: after a change of an algorithm they fail naming the pages, the quoted numbers, the fresh values and
the command that regenerates the snapshot.
"""

import collections
import importlib.util
import json
import os
import pathlib
import sys

import pytest

pytestmark = pytest.mark.docs  # .ci/run's docs step (`-m docs`)

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGES = sorted((ROOT / "docs").rglob("*.md"))


def _load(name):
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


results = _load("_results")


def _quotes():
    """(page, line, case, path, format) of every quote on every page."""
    out = []
    for page in PAGES:
        for k, line in enumerate(page.read_text().splitlines(), start=1):
            for m in results.QUOTE.finditer(line):
                out.append((str(page.relative_to(ROOT)), k, m["case"], m["path"], m["fmt"]))
            for m in results.BENCH.finditer(line):
                out.append((str(page.relative_to(ROOT)), k, "bench:" + m["case"], m["path"], m["fmt"]))
            for m in results.STDOUT.finditer(line):
                out.append((str(page.relative_to(ROOT)), k, m["case"], m["stream"], None))
            for m in results.CALC.finditer(line):  # listed under every case it reads
                for case in dict(results.calc_refs(m["expr"])):
                    out.append((str(page.relative_to(ROOT)), k, case, "calc:" + m["expr"], m["fmt"]))
    return out


def _value(snap, fresh_case=None, fresh=None):
    """A `calc` expression's value reader: snapshot values, except `fresh_case`'s from `fresh`."""

    def value(case, path):
        if case.startswith("bench:"):
            return results.lookup(results.bench(case[6:]), path)
        return results.lookup(fresh if case == fresh_case else snap[case], path)

    return value


QUOTES = _quotes()
BY_CASE = collections.defaultdict(list)
for q in QUOTES:
    BY_CASE[q[2]].append(q)


def test_the_pages_quote_runs():
    assert len(QUOTES) >= 20, "the pages should quote their numbers from the snapshot"


def test_every_quote_resolves_in_the_snapshot():
    snap = results.summaries()
    bad = []
    for page, line, case, path, fmt in QUOTES:
        try:
            if path.startswith("calc:"):
                results.formatted(results.evaluate(path[5:], _value(snap)), fmt)
            elif case.startswith("bench:"):
                results.formatted(results.lookup(results.bench(case[6:]), path), fmt)
            elif not path.startswith("/"):
                assert (results.STUDIES / f"{case}.{path}.txt").exists(), f"no {case}.{path}.txt"
            else:
                results.formatted(results.lookup(snap[case], path), fmt)
        except (KeyError, AssertionError, ValueError, TypeError) as err:
            bad.append(f"{page}:{line}: {case} {path}: {err}")
    assert not bad, "quotes that the snapshot cannot fill:\n" + "\n".join(bad)


def test_the_page_renders_what_it_quotes():
    text = "x {{ run emps-builtin /data/samples ,d }} y"
    snap = results.summaries()
    assert results.render_quotes(text) == f"x {snap['emps-builtin']['data']['samples']:,d} y"
    with pytest.raises(KeyError, match="nope"):
        results.lookup({"a": 1}, "/nope")
    tree = {"p": {"M": {"cov": 0.955}, "Fv": {"cov": 0.97}, "Fc": {"cov": None}}}
    assert results.lookup(tree, "/p/*/cov") == [0.955, 0.97, None]
    assert results.formatted(results.lookup(tree, "/p/*/cov"), "range:.0%") == "96-97"  # None skipped
    assert results.formatted([0.97, 0.97], "range:.0%") == "97" and results.formatted([3, 1], "max:d") == "3"
    assert results.formatted(0.955, ".1%") == "95.5" and results.formatted(2.5, "+.1f") == "+2.5"
    assert results.formatted(["a", "b"], "len") == "2" and results.formatted("MX3", None) == "MX3"
    # exponents without padding or plus sign, as the pages write 1e-9; booleans as yes/no
    assert results.formatted(1.6e-6, ".1e") == "1.6e-6" and results.formatted(2.98e5, ".2e") == "2.98e5"
    assert results.formatted(2.688e-6, "+.4g") == "+2.688e-6" and results.formatted(1e-10, ".0e") == "1e-10"
    assert results.formatted(0.0158, ".3g") == "0.0158" and results.formatted([1e-5, 3e-8], "max:.0e") == "1e-5"
    assert results.formatted(True, "yesno") == "yes" and results.formatted(False, "yesno") == "no"
    assert results.formatted(2.789, "time") == "2.79 s" and results.formatted(0.1154, "time") == "115 ms"
    with pytest.raises(TypeError, match="boolean"):
        results.formatted(1, "yesno")
    rows = {"rows": [{"key": "one", "seconds": 0.5}, {"key": "two", "seconds": 2.0}]}
    assert results.lookup(rows, "/rows/@two/seconds") == 2.0
    with pytest.raises(KeyError, match="keys: one, two"):
        results.lookup(rows, "/rows/@three/seconds")
    # arithmetic on quoted values, and nothing else
    M = snap["emps-real"]["idim_ls"]["M"]
    text = "{{ calc +.2f : ([emps-real /idim_ls/M] - 95.08) / (0.0015 * 95.08) }}"
    assert results.render_quotes(text) == format((M - 95.08) / (0.0015 * 95.08), "+.2f")
    worst = max(snap["emps-real"]["idim_ls"]["rel_std"].values())
    assert results.render_quotes("{{ calc .3f : max([emps-real /idim_ls/rel_std/*]) }}") == format(worst, ".3f")
    for bad in ("__import__('os')", "[emps-real /idim_ls/M].real", "open", "(lambda: 1)()"):
        with pytest.raises(ValueError, match="only arithmetic"):
            results.evaluate(bad, _value(snap))


#: Cases too long to rerun in the suite (1,000 identification studies, 1-2 min each on 2 cores; a minute each
#: for the others): the pages read their saved snapshot like every other, and cheaper cases rerun the same code
#: (`montecarlo-identification-256`, `control-default`, `tx40-real-full`). `JAXSDP_DOCS_SLOW=1` reruns them too.
SLOW_CASES = {
    "montecarlo-identification-1000",
    "montecarlo-identification-1000-spread",
    "montecarlo-control-real-2000",
    "montecarlo-control-covariance-1000",
    "control-real",
    "control-rivcbj-ar095",
    "tx40-real-full-joint5",
    "tx40-real-full-joint6",
}


@pytest.mark.parametrize("case", sorted(c for c in BY_CASE if not c.startswith("bench:")))
def test_quoted_numbers_equal_a_fresh_run(case, tmp_path):
    if case in SLOW_CASES and os.environ.get("JAXSDP_DOCS_SLOW") != "1":
        pytest.skip(f"{case} takes a minute or more; a cheaper case reruns its code (JAXSDP_DOCS_SLOW=1 runs it)")
    snapshot = _load("study_snapshot")
    argv, needs = snapshot.CASES[case]
    missing = [p.name for p in needs if not p.exists()]
    if missing:
        pytest.skip(
            f"the case {case} needs {', '.join(missing)} from the shared data folder (../shared or $JAXSDP_SHARED)"
        )
    assert snapshot.run(tmp_path, [case]) == 0
    fresh = json.loads((tmp_path / f"{case}.json").read_text())
    committed_all = results.summaries()
    committed = committed_all[case]
    bad = []
    for page, line, _, path, fmt in BY_CASE[case]:
        if path.startswith("calc:"):
            old = results.formatted(results.evaluate(path[5:], _value(committed_all)), fmt)
            try:
                new = results.formatted(results.evaluate(path[5:], _value(committed_all, case, fresh)), fmt)
            except KeyError as err:
                new = f"missing ({err})"
            if old != new:
                bad.append(f"{page}:{line}: {path[5:]} quoted {old}, fresh run {new}")
            continue
        if not path.startswith("/"):
            old = (results.STUDIES / f"{case}.{path}.txt").read_text().splitlines()
            new = (tmp_path / f"{case}.{path}.txt").read_text().splitlines()
            if old != new:
                changed = next(f"{a!r} -> {b!r}" for a, b in zip(old + [""], new + [""]) if a != b)
                bad.append(f"{page}:{line}: the {path} of {case} changed, first line: {changed}")
            continue
        old = results.formatted(results.lookup(committed, path), fmt)
        try:
            new = results.formatted(results.lookup(fresh, path), fmt)
        except KeyError as err:
            new = f"missing ({err})"
        if old != new:
            bad.append(f"{page}:{line}: {path} quoted {old}, fresh run {new}")
    assert not bad, (
        f"the pages quote numbers of {case} that a fresh run no longer gives; regenerate the snapshot with "
        f"`python benchmarks/study_snapshot.py run benchmarks/results/studies --only {case}`, read the changed "
        "pages and commit both:\n" + "\n".join(bad)
    )
