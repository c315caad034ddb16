#!/usr/bin/env bash
# The GPU benchmarks in one go, each under its own time limit, for a GPU machine
# lent for minutes: logs and JSON files into OUTDIR (default: benchmarks/results/gpu).
# The performance page's GPU figures are read from these JSON files.
#
#   bash benchmarks/gpu_all.sh [OUTDIR]
set -u
out=${1:-benchmarks/results/gpu}
mkdir -p "$out"
export PYTHONUNBUFFERED=1
py=${PYTHON:-python3}
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>&1; date -u +%F; "$py" -c "import jax, jaxsdp; print('jax', jax.__version__, jax.devices())" 2>&1; } | tee "$out/env.txt"
timeout "${GPU_BENCH_LIMIT:-240}" "$py" benchmarks/gpu.py --batch 2000 --runs 10000 --repeats 3 --json "$out/gpu.json" 2>&1 | tee "$out/gpu.txt"
timeout "${MC_BENCH_LIMIT:-150}" "$py" benchmarks/montecarlo.py --runs 10000 100000 --vmap-max 10000 \
    --ident-runs 1000 --control-runs 10000 100000 --json "$out/montecarlo.json" 2>&1 | tee "$out/montecarlo.txt"
timeout "${ROBOT_BENCH_LIMIT:-90}" "$py" benchmarks/robot_stacked.py --json "$out/robot_stacked.json" 2>&1 | tee "$out/robot_stacked.txt"
