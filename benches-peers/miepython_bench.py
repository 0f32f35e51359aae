"""Time miepython (numba JIT) on the work `lucent bench mie` times: Q's and g for one sphere,
m = 1.5+0.01i, x = 10, 100, 1000, one thread. Prints microseconds per evaluation (best of 5 batches).
Usage: pip install miepython numba && python3 benches-peers/miepython_bench.py"""
import json
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")
os.environ["MIEPYTHON_USE_JIT"] = "1"  # miepython 3 selects its numba backend at import
import miepython  # noqa: E402


m = complex(1.5, -0.01)  # miepython uses n - ik for absorbing spheres
out = {}
for x in (10.0, 100.0, 1000.0):
    miepython.efficiencies_mx(m, x)  # JIT warm-up
    assert miepython._backend.USE_JIT
    reps = max(200, int(2e5 / x))
    best = float("inf")
    for _ in range(5):
        t0 = time.perf_counter()
        for _ in range(reps):
            miepython.efficiencies_mx(m, x)
        best = min(best, (time.perf_counter() - t0) / reps)
    out[f"miepython_us_x{int(x)}"] = best * 1e6
print(json.dumps(out))
