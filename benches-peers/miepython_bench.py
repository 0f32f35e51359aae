"""Time miepython (numba JIT) on the work `lucent bench mie` times: Q's and g for one sphere,
m = 1.5+0.01i, x = 10, 100, 1000, one thread. Prints microseconds per evaluation: the best of
200 batches of about 2 ms each (as `lucent bench mie` and the example `mie_time` take the best
batch), which stays near the unloaded figure when other processes share the cores.
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
    t0 = time.perf_counter()
    miepython.efficiencies_mx(m, x)
    one = max(time.perf_counter() - t0, 1e-7)
    reps = max(1, int(2e-3 / one))
    best = float("inf")
    for _ in range(200):
        t0 = time.perf_counter()
        for _ in range(reps):
            miepython.efficiencies_mx(m, x)
        best = min(best, (time.perf_counter() - t0) / reps)
    out[f"miepython_us_x{int(x)}"] = best * 1e6
print(json.dumps(out))
