"""Issue 41, item 1: float64 whatever the caller's JAX setting.

Every public callable of every public subpackage (and the methods users call on models and results) runs
under `jaxsdp._runtime.x64`; with JAX's 64-bit mode off it returns the float64 result it returns with 64-bit
mode on (1e-12 relative), or, inside the caller's own `jax.jit`/`grad`/`vmap`, raises `Float64Error` at trace
time naming the one line that enables 64-bit mode. The cases are in `tests/float64_cases.py`; this file walks
every public name, so a new one without the decorator, or without a case or a stated reason, fails here.
"""

import importlib
import inspect
import os
import pickle
import pkgutil
import re
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import float64_cases as fc
import jaxsdp
from helpers import EXAMPLE_ROBOTS, requires_example_robots, requires_tx40_urdf
from jaxsdp._runtime import X64_LINE, Float64Error, is_x64

# one worker runs the file (`--dist loadgroup`), so that its module and session fixtures run once
pytestmark = pytest.mark.xdist_group("float64")

#: Settings functions: they take and return strings, never arrays.
SETTINGS = {"fast_loops_status", "kernel_method", "resolve_method", "set_kernel_method"}
#: Host-side text and figure functions of the studies (summaries, reports, figures of a study result).
TEXT_NAME = re.compile(r"(summary|report|text|fig|figures|findings|save_|write_|comparison|recovery)")


def _public_modules():
    names = ["jaxsdp"]
    for info in pkgutil.walk_packages(jaxsdp.__path__, "jaxsdp."):
        if not any(part.startswith("_") for part in info.name.split(".")[1:]):
            names.append(info.name)
    return [importlib.import_module(n) for n in names]


def _public_objects():
    """{id: (sorted qualified names, object)} of every public callable (functions and classes)."""
    out = {}
    for mod in _public_modules():
        for name in getattr(mod, "__all__", ()):
            obj = getattr(mod, name)
            if inspect.ismodule(obj) or not callable(obj):
                continue
            names, _ = out.setdefault(id(obj), ([], obj))
            names.append(f"{mod.__name__}.{name}")
    return out


def _members(cls):
    """The public methods, properties, classmethods and a hand-written `__init__` defined on `cls` itself."""
    for attr, value in vars(cls).items():
        if attr.startswith("_") and attr not in ("__init__", "__call__"):
            continue
        fn = value
        if isinstance(value, (classmethod, staticmethod)):
            fn = value.__func__
        elif isinstance(value, property):
            fn = value.fget
        if not inspect.isfunction(fn) or getattr(fn, "__isabstractmethod__", False):
            continue
        code = getattr(inspect.unwrap(fn), "__code__", None)
        if code is None or not code.co_filename.endswith(".py"):  # dataclass-generated __init__
            continue
        yield attr, value


def test_every_public_callable_runs_under_x64():
    missing = []
    for names, obj in _public_objects().values():
        if inspect.isclass(obj):
            if issubclass(obj, BaseException):
                continue
            missing += [f"{names[0]}.{attr}" for attr, value in _members(obj) if not is_x64(value)]
        elif names[0].rsplit(".", 1)[1] not in SETTINGS and not is_x64(obj):
            missing.append(names[0])
    assert not missing, f"public callables not decorated with jaxsdp._runtime.x64: {sorted(missing)}"


def _types_in(tree, seen=None):
    """The classes of every node of a result (Modules, dataclasses, NamedTuples, containers)."""
    seen = set() if seen is None else seen
    seen.add(type(tree))
    if isinstance(tree, dict):
        children = tree.values()
    elif isinstance(tree, (list, tuple)):
        children = tree
    elif hasattr(tree, "__dataclass_fields__"):
        children = [getattr(tree, f, None) for f in tree.__dataclass_fields__]
    else:
        children = ()
    for child in children:
        if not isinstance(child, (np.ndarray, jax.Array)):
            _types_in(child, seen)
    return seen


@pytest.fixture(scope="module")
def x64_on_results():
    """Every case run here, where 64-bit mode is on (conftest): {name: leaves}, and the types in the results."""
    assert jax.config.jax_enable_x64
    results, types = {}, set()
    for name, case in fc.cases().items():
        result = case()
        types |= _types_in(result)
        results[name] = fc.leaves(result)
    return results, types


@pytest.fixture(scope="module")
def x64_off_results(tmp_path_factory):
    """Every case run in a fresh process that never enables 64-bit mode (import-time constants included)."""
    out = tmp_path_factory.mktemp("float64") / "off.pkl"
    env = dict(os.environ, JAX_ENABLE_X64="0")
    script = os.path.join(os.path.dirname(__file__), "float64_cases.py")
    proc = subprocess.run([sys.executable, script, str(out)], env=env, capture_output=True, text=True, timeout=1200)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return pickle.loads(out.read_bytes())


def test_every_public_callable_has_a_case_or_a_reason(x64_on_results):
    _, types = x64_on_results
    cased = set(fc.cases()) | set(fc.ELSEWHERE)
    cased |= {name.rsplit(".", 1)[0] for name in fc.cases()}  # a method's case covers its class
    missing = []
    for names, obj in _public_objects().values():
        if inspect.isclass(obj) and (obj in types or issubclass(obj, BaseException)):
            continue
        if set(names) & cased:
            continue
        if any(n.rsplit(".", 1)[0] in fc.TEXT_MODULES and TEXT_NAME.search(n.rsplit(".", 1)[1]) for n in names):
            continue  # text and figures of a study result
        missing.append(names[0])
    assert not missing, f"public callables with no case and no reason in tests/float64_cases.py: {sorted(missing)}"
    stale = sorted(set(fc.ELSEWHERE) - {n for names, _ in _public_objects().values() for n in names})
    assert not stale, f"ELSEWHERE names no public callable: {stale}"


def test_x64_off_gives_the_x64_on_result(x64_on_results, x64_off_results):
    on, _ = x64_on_results
    assert set(x64_off_results) == set(on)
    problems = []
    for name, off_leaves in x64_off_results.items():
        if len(off_leaves) != len(on[name]):
            problems.append(f"{name}: {len(off_leaves)} leaves with 64-bit off, {len(on[name])} with it on")
            continue
        for k, (a, b) in enumerate(zip(off_leaves, on[name])):
            if a.dtype.kind in "fc" and a.dtype not in (np.float64, np.complex128):
                problems.append(f"{name}, leaf {k}: {a.dtype} with 64-bit off")
            elif a.shape != b.shape:
                problems.append(f"{name}, leaf {k}: shape {a.shape} with 64-bit off, {b.shape} on")
            elif a.dtype.kind in "fc":
                scale = np.max(np.abs(b[np.isfinite(b)]), initial=0.0)
                same_nan = np.array_equal(np.isfinite(a), np.isfinite(b))
                close = np.allclose(a[np.isfinite(a)], b[np.isfinite(b)], rtol=1e-12, atol=1e-12 * scale)
                if not (same_nan and close):
                    err = np.max(np.abs(a - b)) / max(scale, 1e-300)
                    problems.append(f"{name}, leaf {k}: differs by {err:.2e} relative to its largest value")
            elif not np.array_equal(a, b):
                problems.append(f"{name}, leaf {k}: {a} with 64-bit off, {b} on")
    assert not problems, "\n".join(problems)


# --------------------------------------------------------------------------- #
# Inside the caller's own transformations with 64-bit mode off: one clear error
# --------------------------------------------------------------------------- #


def _series():
    rng = np.random.default_rng(0)
    x = rng.standard_normal((200, 1))
    return x[:, 0] * 2.0 + 0.1 * rng.standard_normal(200), x


@pytest.mark.parametrize("transform", ["grad", "jit", "vmap", "closure"])
def test_traced_calls_with_x64_off_name_the_fix(transform):
    y, X = _series()
    calls = {
        "grad": lambda: jax.grad(lambda lam: jnp.sum(jaxsdp.dlr(y, X, nvr=10.0**lam).par))(-2.0),
        "jit": lambda: jax.jit(lambda yy: jaxsdp.dlr(yy, X, nvr=1e-2).par)(y),
        "vmap": lambda: jax.vmap(lambda yy: jaxsdp.dlr(yy, X, nvr=1e-2).par)(np.stack([y, y])),
        # no traced argument: the trace state tells
        "closure": lambda: jax.jit(lambda s: s + jaxsdp.dlr(y, X, nvr=1e-2).par.sum())(1.0),
    }
    with jax.enable_x64(False), pytest.raises(Float64Error) as err:
        calls[transform]()
    assert "64-bit mode" in str(err.value) and X64_LINE in str(err.value)


def test_traced_method_with_x64_off_names_the_fix():
    robot = jaxsdp.plants.tx40_robot()
    with jax.enable_x64(False), pytest.raises(Float64Error, match="64-bit mode"):
        jax.jit(lambda q: robot.inverse_dynamics(q, q, q))(np.zeros(6))


def test_gradient_through_dlr_with_x64_on_is_unchanged():
    y, X = _series()
    g = jax.grad(lambda lam: jnp.sum(jaxsdp.dlr(y, X, nvr=10.0**lam).par))(-2.0)
    assert g.dtype == jnp.float64 and np.isfinite(g)


def test_float32_inputs_are_computed_in_float64_with_a_warning():
    y, X = _series()
    with jax.enable_x64(False):
        y32 = jnp.asarray(y)
        with pytest.warns(jaxsdp.Float64Warning, match="float32"):
            res = jaxsdp.idim_ls(y32, X)
    assert res.theta.dtype == np.float64


def _pinocchio_check(path):
    pin = pytest.importorskip("pinocchio")
    from jaxsdp.plants import SerialRobot

    with jax.enable_x64(False):
        robot = SerialRobot.from_urdf(path)
        assert all(np.asarray(x).dtype == np.float64 for x in jax.tree.leaves(robot) if hasattr(x, "dtype"))
        rng = np.random.default_rng(0)
        q, dq, ddq = (rng.standard_normal(robot.n) for _ in range(3))
        tau = robot.inverse_dynamics(q, dq, ddq)
    model = pin.buildModelFromUrdf(str(path))
    ref = pin.rnea(model, model.createData(), q, dq, ddq)
    assert tau.dtype == np.float64
    np.testing.assert_allclose(tau, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))


@requires_tx40_urdf
def test_tx40_file_with_x64_off_equals_pinocchio():
    from helpers import TX40_URDF

    _pinocchio_check(TX40_URDF)


@requires_example_robots
def test_another_robot_with_x64_off_equals_pinocchio():
    _pinocchio_check(EXAMPLE_ROBOTS / "ur_description" / "urdf" / "ur5_robot.urdf")
