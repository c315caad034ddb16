"""The Monte Carlo runner (issue 18, item 1): chunking, sharding, reproducibility, progress."""

import json
import os
import pathlib
import subprocess
import sys

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import jaxsdp

ROOT = pathlib.Path(__file__).resolve().parents[1]


def _walk(k, p):
    # a draw with reductions over a long axis: their order depends on the vmap width
    # unless the runner keeps it fixed
    x = jax.random.normal(k, (500,))
    y = jnp.cumsum(x * p["a"])
    return {"mean": jnp.mean(y), "std": jnp.std(y), "peak": jnp.max(jnp.abs(y)), "head": y[:3]}


N = 103
PARAMS = {"a": np.linspace(0.5, 1.5, N)}


def _leaves_equal(a, b):
    return all(np.array_equal(u, v) for u, v in zip(jax.tree.leaves(a), jax.tree.leaves(b)))


def test_values_are_fn_of_the_folded_keys():
    key = jax.random.key(7)
    out = jaxsdp.monte_carlo(lambda k: jax.random.uniform(k, (2,)), key, 10, chunk_size=4, progress=False)
    ref = np.stack([np.asarray(jax.random.uniform(jax.random.fold_in(key, i), (2,))) for i in range(10)])
    np.testing.assert_array_equal(out.values, ref)
    assert out.runs == 10 and out.devices == len(jax.devices()) and out.chunk_size % 16 == 0
    assert out.seconds > 0 and out.runs_per_second > 0
    # an int seed is jax.random.key(seed); a raw uint32[2] key works too
    a = jaxsdp.monte_carlo(lambda k: jax.random.normal(k), 3, 5, progress=False).values
    b = jaxsdp.monte_carlo(lambda k: jax.random.normal(k), jax.random.key(3), 5, progress=False).values
    c = jaxsdp.monte_carlo(lambda k: jax.random.normal(k), jax.random.PRNGKey(3), 5, progress=False).values
    assert np.array_equal(a, b) and np.array_equal(a, c)


def test_bit_identical_for_any_chunk_size():
    runs = [
        jaxsdp.monte_carlo(_walk, jax.random.key(3), N, params=PARAMS, chunk_size=c, progress=False)
        for c in (1, 7, 64, 200)
    ]
    for r in runs[1:]:
        assert _leaves_equal(r.values, runs[0].values)
    assert runs[0].values["head"].shape == (N, 3)


_SUBPROCESS = """
import json, sys, jax, numpy as np
import jaxsdp
sys.path.insert(0, {tests!r})
from test_montecarlo import PARAMS, N, _walk
with jax.enable_x64(True):
    out = {{}}
    for d, c in ((4, 8), (4, 100), (2, 40), (1, 16)):
        r = jaxsdp.monte_carlo(_walk, jax.random.key(3), N, params=PARAMS, devices=d, chunk_size=c, progress=False)
        out[f"{{d}}-{{c}}"] = [r.devices, r.chunk_size, np.asarray(r.values["mean"]).tobytes().hex(),
                              np.asarray(r.values["head"]).tobytes().hex()]
print(json.dumps(dict(n=len(jax.devices()), out=out)))
"""


def test_bit_identical_on_four_host_devices():
    env = dict(os.environ, XLA_FLAGS="--xla_force_host_platform_device_count=4", JAX_PLATFORMS="cpu")
    code = _SUBPROCESS.format(tests=str(ROOT / "tests"))
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    res = json.loads(proc.stdout.strip().splitlines()[-1])
    assert res["n"] == 4
    with jax.enable_x64(True):
        ref = jaxsdp.monte_carlo(_walk, jax.random.key(3), N, params=PARAMS, progress=False).values
    for name, (devices, chunk, mean_hex, head_hex) in res["out"].items():
        assert devices == int(name.split("-")[0]) and chunk % (16 * devices) == 0
        assert mean_hex == np.asarray(ref["mean"]).tobytes().hex(), name
        assert head_hex == np.asarray(ref["head"]).tobytes().hex(), name


def test_bad_arguments():
    f = lambda k: jax.random.normal(k)
    for bad in (0, -3, 2.5, True):
        with pytest.raises(ValueError, match="`n` must be an integer >= 1"):
            jaxsdp.monte_carlo(f, 0, bad, progress=False)
    with pytest.raises(ValueError, match="`chunk_size` must be an integer >= 1"):
        jaxsdp.monte_carlo(f, 0, 4, chunk_size=0, progress=False)
    with pytest.raises(ValueError, match="`key` must be a PRNG key"):
        jaxsdp.monte_carlo(f, "seed", 4, progress=False)
    with pytest.raises(ValueError, match="`params` must be a pytree of arrays with leading axis n = 4"):
        jaxsdp.monte_carlo(lambda k, p: p, 0, 4, params={"a": np.ones(5)}, progress=False)
    with pytest.raises(ValueError, match="`devices`"):
        jaxsdp.monte_carlo(f, 0, 4, devices=len(jax.devices()) + 1, progress=False)


def test_no_progress_output_off_a_terminal(capfd):
    jaxsdp.monte_carlo(lambda k: jax.random.normal(k), 0, 40, chunk_size=16, progress=True)
    out, err = capfd.readouterr()
    assert out == "" and err == ""  # stderr is not a terminal under pytest


def test_emps_closed_loop_statistics_through_the_runner():
    # per-run statistics of the EMPS closed loop on drawn plants: the shape a study uses
    from jaxsdp.data import emps_builtin_reference
    from jaxsdp.plants import EMPSPlant, LinearFriction, simulate_emps

    qg = jnp.asarray(emps_builtin_reference(n=2000).q)
    theta = np.array([95.1, 203.5, 20.4, -3.2])
    scale = 1.0 + 0.2 * (np.random.default_rng(0).random((12, 4)) - 0.5)

    def run(key, s):
        plant = EMPSPlant(theta[0] * s[0], LinearFriction(*(theta[1:] * s[1:])))
        sim = simulate_emps(qg, plant=plant)
        return jnp.stack([jnp.max(jnp.abs(sim.q - qg)), jnp.max(jnp.abs(sim.force))])

    with jax.enable_x64(True):
        out = jaxsdp.monte_carlo(run, 0, 12, params=scale, chunk_size=16, progress=False)
        one = run(None, jnp.asarray(scale[5]))
    assert out.values.shape == (12, 2) and np.all(np.isfinite(out.values))
    np.testing.assert_allclose(out.values[5], one, rtol=1e-12)
