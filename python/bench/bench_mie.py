"""Time lucent's Python package against miepython on the same work, in one run.

1. Mie: Q's and g for 10⁴ size parameters x log-spaced over [1, 1000], m = 1.5 + 0.01i:
   lucent.mie(x, m) on one thread and on all cores, against miepython's vectorised
   efficiencies_mx(m*, x) with its numba backend (JIT warmed up first).
2. Milk: lucent.milk(3.5) (17 wavelengths, no phase table, as the command computes it) in
   process, against `lucent medium milk --fat-percent 3.5 --json` as a process.

Prints one JSON object (seconds, best of the repeats; wall-clock, and CPU time of this process
for the single-threaded pair). Usage, from the repository root:
    pip install ./python miepython numba && python3 python/bench/bench_mie.py [--lucent target/release/lucent]
"""

import argparse
import json
import os
import subprocess
import time

os.environ["MIEPYTHON_USE_JIT"] = "1"  # miepython 3 picks its numba backend at import
# numpy's OpenBLAS keeps threads spinning after its calls, which count in this process's CPU time
# and take a core from the threads timed here; both Mie codes run without BLAS.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import lucent  # noqa: E402


def best(f, repeats, clock=time.perf_counter):
    t = float("inf")
    for _ in range(repeats):
        t0 = clock()
        f()
        t = min(t, clock() - t0)
    return t


def cpu(f, repeats):
    """Best CPU time of this process (less sensitive than wall-clock time to other load)."""
    return best(f, repeats, time.process_time)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--lucent", default=None, help="the lucent command (default: target/release/lucent, else target/debug/lucent)")
    ap.add_argument("--repeats", type=int, default=5)
    a = ap.parse_args()
    out = {}
    x = np.geomspace(1.0, 1000.0, 10_000)
    m = 1.5 + 0.01j
    out["sizes"] = len(x)
    out["lucent_mie_1_thread_s"] = best(lambda: lucent.mie(x, m, threads=1), a.repeats)
    out["lucent_mie_all_threads_s"] = best(lambda: lucent.mie(x, m), a.repeats)
    out["threads"] = os.cpu_count()
    try:
        import miepython

        miepython.efficiencies_mx(m.conjugate(), x[:10])  # JIT warm-up
        out["miepython_version"] = miepython.__version__
        out["miepython_jit"] = bool(miepython._backend.USE_JIT)
        out["miepython_efficiencies_mx_s"] = best(lambda: miepython.efficiencies_mx(m.conjugate(), x), a.repeats)
        q = miepython.efficiencies_mx(m.conjugate(), x)
        r = lucent.mie(x, m)
        out["max_rel_diff_qext"] = float(np.max(np.abs(r.qext - q[0]) / np.abs(q[0])))
        out["max_rel_diff_g"] = float(np.max(np.abs(r.g - q[3]) / np.abs(q[3])))
        out["lucent_mie_1_thread_cpu_s"] = cpu(lambda: lucent.mie(x, m, threads=1), a.repeats)
        out["miepython_efficiencies_mx_cpu_s"] = cpu(lambda: miepython.efficiencies_mx(m.conjugate(), x), a.repeats)
        out["speedup_1_thread_cpu"] = out["miepython_efficiencies_mx_cpu_s"] / out["lucent_mie_1_thread_cpu_s"]
        out["speedup_1_thread"] = out["miepython_efficiencies_mx_s"] / out["lucent_mie_1_thread_s"]
        out["speedup_all_threads"] = out["miepython_efficiencies_mx_s"] / out["lucent_mie_all_threads_s"]
    except ImportError:
        out["miepython"] = "not installed"

    out["lucent_milk_in_process_s"] = best(lambda: lucent.milk(3.5, phase_angles=0), a.repeats)
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    exe = a.lucent or next((p for p in (os.path.join(root, "target", d, "lucent") for d in ("release", "debug")) if os.path.isfile(p)), None)
    if exe:
        cmd = [exe, "medium", "milk", "--fat-percent", "3.5", "--json"]
        out["lucent_cli"] = exe
        out["lucent_milk_cli_process_s"] = best(lambda: subprocess.run(cmd, check=True, capture_output=True), a.repeats)
        j = json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout)
        out["milk_equal_to_cli"] = lucent.milk(3.5, phase_angles=0).sigma_s_per_mm.tolist() == j["sigma_s_per_mm"]
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
