"""Where a loop member's time goes, by compiled function: run it under Linux ``perf``.

Usage::

    perf record -o member.data python benchmarks/profile_loop_member.py sensors --steps 2000000
    perf report -i member.data --sort sym --stdio | head -40
    perf record -o plain.data python benchmarks/profile_loop_member.py true-state --steps 2000000
    perf record -o member.data python benchmarks/profile_loop_member.py sensors --steps 20000 --repeat 100
    perf record -o gnc.data python benchmarks/profile_loop_member.py gnc-grid --steps 20000 --repeat 100 --keep /tmp/objs

The member is ``bench_loop_sensors.py``'s (``sensors``: a gyro, a star tracker and the MEKF at 2 Hz,
the controller on the estimate; ``true-state``: the controller on the truth). Numba's compiled code
has no symbols ``perf`` can see; this script keeps the object code of the loop's library as Numba
loads it (from its cache or a compilation), reads the functions' offsets and sizes in it with
``objdump -t`` and writes them, at the addresses where the code was loaded, into
``/tmp/perf-<pid>.map``, which ``perf report`` reads. Each function the loop calls (``advance_free``,
``sensor_dispatch``, ``estimator_dispatch``, ...) is a symbol; helpers inlined into one count in it
(``record_fast`` and ``writes_finite`` in ``loop_steps``). Kernel time (page faults of new record
memory: ``clear_page_erms``) shows under its own names. A sample is 250 us of CPU time at perf's
default rate, so ``samples * 250 us / steps`` is the time a step (``steps`` times ``--repeat``). One long run
writes all its records to new memory (the kernel's page zeroing shows); ``--repeat`` runs the
benchmark's length again and again, as ``bench_loop_sensors.py`` does. Needs ``perf`` and ``objdump``.
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba.core.codegen as _codegen
import numpy as np

_OBJECTS: list = []
_set_object = _codegen.CPUCodeLibrary._set_compiled_object
_compiled_hook = _codegen.CPUCodeLibrary._object_compiled_hook.__func__


def _keep_loaded(self, value):                 # a library loaded from Numba's cache
    _OBJECTS.append((self, bytes(value)))
    return _set_object(self, value)


def _keep_compiled(cls, ll_module, buf):       # a library compiled in this process
    lib = getattr(ll_module, "_CPUCodeLibrary__library", None)
    if lib is not None:
        _OBJECTS.append((lib, bytes(buf)))
    return _compiled_hook(cls, ll_module, buf)


_codegen.CPUCodeLibrary._set_compiled_object = _keep_loaded
_codegen.CPUCodeLibrary._object_compiled_hook = classmethod(_keep_compiled)

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_loop_sensors as bench  # noqa: E402


def _short(name: str) -> str:
    """``lgvi._kernels.loop_kernels.loop_steps`` for Numba's mangled ``_ZN4lgvi8_kernels12loop_kernels10loop_steps...``."""
    i = name.find("_ZN")
    if i < 0:
        return name
    i += 3
    parts = []
    while i < len(name) and name[i].isdigit():
        j = i
        while name[j].isdigit():
            j += 1
        n = int(name[i:j])
        parts.append(name[j:j + n])
        i = j + n
    return (name[:name.find("_ZN")] + ".".join(parts)) if parts else name


def write_perf_map(keep: str | None = None) -> int:
    """``/tmp/perf-<pid>.map`` with every function of the compiled libraries kept; their count. With
    ``keep`` (a folder), each library's object file is also written there as ``lib<i>.o`` with its
    load address in ``bases.txt`` (``<i> <base, hex>``), so that a sample's address less the base
    is an offset ``objdump -d -l`` shows (line numbers when the kernels were compiled with
    ``NUMBA_DEBUGINFO=1`` into a private ``NUMBA_CACHE_DIR``)."""
    lines = []
    bases = []
    with tempfile.TemporaryDirectory() as tmp:
        for i, (lib, obj) in enumerate(_OBJECTS):
            path = os.path.join(tmp, f"lib{i}.o")
            with open(path, "wb") as fh:
                fh.write(obj)
            table = subprocess.run(["objdump", "-t", path], capture_output=True, text=True).stdout
            funcs = []
            for ln in table.splitlines():
                m = re.match(r"([0-9a-f]+)\s.*\sF\s+\S*text\s+([0-9a-f]+)\s+(\S+)$", ln)
                if m:
                    funcs.append((int(m.group(1), 16), int(m.group(2), 16), m.group(3)))
            base = None
            for off, _, name in funcs:          # where the library's code was loaded: one global symbol
                try:
                    addr = lib.get_pointer_to_function(name)
                except Exception:  # noqa: BLE001 - a local symbol the engine does not export
                    addr = 0
                if addr:
                    base = addr - off
                    break
            if base is None:
                continue
            if keep:
                os.makedirs(keep, exist_ok=True)
                with open(os.path.join(keep, f"lib{i}.o"), "wb") as fh:
                    fh.write(obj)
                bases.append(f"{i} {base:x}")
            for off, size, name in funcs:
                lines.append(f"{base + off:x} {max(size, 1):x} {_short(name)}")
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as fh:
        fh.write("\n".join(lines) + "\n")
    if keep:
        with open(os.path.join(keep, "bases.txt"), "w") as fh:
            fh.write("\n".join(bases) + "\n")
    return len(lines)


def _case(name: str, steps: int):
    """The run of ``name``: a member of :func:`bench.member_cases`, or ``gnc-grid`` (the tumbling 6U
    under every disturbance at a GNC engineer's rates, the records on the grid: issue 26 part 5's
    case, ``bench_loop_sensors.py``'s ``all dist., GNC rates, grid``)."""
    if name == "gnc-grid":
        from scipy.spatial.transform import Rotation

        sc, _ = bench.six_u(bench.ADDED, env_rate=1.0, rates=bench.GNC)
        d = bench._basilisk_6u()[1]
        R6 = Rotation.from_mrp(d["sigma0"]).as_matrix()
        fsw = bench._records("grid")
        return lambda: bench.lgvi.simulate(sc, R6, omega0=d["omega0"], fsw=fsw, h=bench.H, steps=steps,
                                           save_every=steps)
    sensed, est, plain = bench._members()
    fsw = bench._fsw(est if name == "sensors" else None)
    return lambda: bench.lgvi.simulate(sensed if name == "sensors" else plain, np.eye(3), omega0=bench.OMEGA0,
                                       fsw=fsw, h=bench.H, steps=steps, save_every=steps)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("member", choices=("sensors", "true-state", "gnc-grid"))
    ap.add_argument("--steps", type=int, default=2_000_000)
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs of --steps steps (e.g. --steps 20000 --repeat 100: the benchmark's run length)")
    ap.add_argument("--keep", default=None, help="a folder for the object files and their load addresses")
    args = ap.parse_args()
    _case(args.member, 1000)()                  # load or compile the loop
    print(f"{write_perf_map(args.keep)} compiled functions named in /tmp/perf-{os.getpid()}.map")
    run = _case(args.member, args.steps)
    t = time.process_time()
    for _ in range(args.repeat):
        run()
    n = args.steps * args.repeat
    print(f"{args.member}: {(time.process_time() - t) / n * 1e6:.3f} us a step (CPU time, {args.repeat} x {args.steps} "
          "steps)")


if __name__ == "__main__":
    main()
