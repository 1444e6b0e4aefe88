#!/usr/bin/env bash
# One prepared run on a machine with an NVIDIA GPU (the project's lent H100: one command of at most
# 10 minutes). From the repository root:
#
#     bash benchmarks/gpu_session.sh [OUT]          # OUT: where the logs go (default $OUT, else .)
#
# Uses the machine's python3 (its NumPy, SciPy, Numba, numba-cuda, tqdm) with this tree on the path;
# nothing is installed. Writes:
#   gpu_env.txt    versions, the GPU, the kernels' PTX check (benchmarks/gpu_ptx.py)
#   bench_gpu.txt  the table of benchmarks/bench_gpu.py (GPU beside the CPU's cores, same run)
#   gpu_tests.txt  tests/test_gpu.py on the GPU (LGVI_TEST_CUDA=hardware), if time is left
# Budget: one to two minutes of compiles for the CPU's kernels on a bare machine (no Numba cache), about
# one of the GPU's, the runs a minute or two (the table is cut at 7 minutes, its rows printed as they come); the
# tests get what is left of 9 minutes.
set -uo pipefail
cd "$(dirname "$0")/.."
out="${1:-${OUT:-.}}"
mkdir -p "$out"
export PYTHONPATH="$PWD/src${PYTHONPATH:+:$PYTHONPATH}" PYTHONUNBUFFERED=1
unset NUMBA_ENABLE_CUDASIM
start=$SECONDS
py=python3
{
    date -u
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv || true
    $py -c "import numpy, numba, scipy; print('numpy', numpy.__version__, 'numba', numba.__version__, 'scipy', scipy.__version__)"
    $py -m pip show numba-cuda 2>/dev/null | head -2
    $py -c "import lgvi, numpy as np; from lgvi import gpu; print('row_stack shim needed:', gpu.numpy_shim()); c = gpu.cuda_module(); print('cuda:', c.get_current_device().name, 'simulator:', gpu.simulator(c))"
} >"$out/gpu_env.txt" 2>&1
cat "$out/gpu_env.txt"
timeout 420 $py benchmarks/bench_gpu.py 2>&1 | tee "$out/bench_gpu.txt"
left=$(( 540 - (SECONDS - start) ))
if (( left > 60 )); then
    LGVI_TEST_CUDA=hardware timeout "$left" $py -m pytest -q -p no:cacheprovider tests/test_gpu.py \
        -k "not smoke and not core_never" 2>&1 | tail -40 | tee "$out/gpu_tests.txt"
fi
echo "done in $(( SECONDS - start )) s"
