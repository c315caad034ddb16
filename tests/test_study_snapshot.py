"""The before/after summary.json comparison of `benchmarks/study_snapshot.py` (issue 28, item 6) finds what differs."""

import importlib.util
import pathlib

SCRIPT = pathlib.Path(__file__).resolve().parents[1] / "benchmarks" / "study_snapshot.py"
spec = importlib.util.spec_from_file_location("study_snapshot", SCRIPT)
snapshot = importlib.util.module_from_spec(spec)
spec.loader.exec_module(snapshot)


def test_strip_drops_the_run_to_run_keys_at_any_depth():
    tree = {"timings": {"a": 1.0}, "x": [{"seconds": 2.0, "y": 3}], "versions": {}, "z": {"runs_per_second": 5}}
    assert snapshot.strip(tree) == {"x": [{"y": 3}], "z": {}}


def test_differences_finds_numbers_strings_keys_and_lengths():
    a = {"m": 95.1826, "w": ["fine"], "k": 1, "n": [1, 2], "nan": float("nan")}
    assert list(snapshot.differences(a, a)) == []
    b = {"m": 95.1827, "w": ["fragile"], "n": [1], "extra": True, "nan": float("nan")}
    found = "\n".join(snapshot.differences(a, b))
    for part in ("/m: 95.1826 -> 95.1827", "/w[0]: 'fine' -> 'fragile'", "/k: missing after", "/extra: missing before"):
        assert part in found, found
    assert "/n: length 2 -> 1" in found
    assert list(snapshot.differences({"m": 1.0}, {"m": 1.0 + 1e-13}, rtol=1e-12)) == []
    assert list(snapshot.differences({"m": 1.0}, {"m": 1.0 + 1e-13})) != []  # rtol 0: bit for bit
    assert list(snapshot.differences({"f": True}, {"f": False})) == ["/f: True -> False"]


def test_compare_exits_1_on_any_difference(tmp_path):
    before, after = tmp_path / "before", tmp_path / "after"
    before.mkdir(), after.mkdir()
    (before / "emps.json").write_text('{"m": 1.0}')
    (after / "emps.json").write_text('{"m": 1.0}')
    assert snapshot.main(["compare", str(before), str(after)]) == 0
    (after / "emps.json").write_text('{"m": 2.0}')
    assert snapshot.main(["compare", str(before), str(after)]) == 1
    (after / "emps.json").write_text('{"m": 1.0}')
    (after / "tx40.json").write_text("{}")
    assert snapshot.main(["compare", str(before), str(after)]) == 1  # a case only on one side
