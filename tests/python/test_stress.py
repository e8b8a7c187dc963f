"""Numerical stress through the module: a 16384 x 8192 source bakes in memory
proportional to the image (the rest of the stress tests are in
tests/native/test_stress.cpp)."""
import json
import os
import subprocess
import sys

BAKE_BIG = """
import json, numpy as np, iblbake_core as ib
img = np.full((8192, 16384, 3), 0.5, np.float32)
img[1000:1004, 3000:3004] = 1e5          # a small sun
img[4096:, :, 2] = 2.0                   # a brighter lower hemisphere in blue
r = ib.bake(img, lut=False)
ok = bool(np.isfinite(r["irradiance"]).all() and all(np.isfinite(s).all() for s in r["specular"]))
print(json.dumps({"finite": ok, "irr_min": float(r["irradiance"].min())}))
"""


def test_16k_source_memory_stays_proportional():
    # The source as float32 RGB is 1.61 GB; the bake keeps the caller's array,
    # its own copy and the integration structures: peak RSS must stay under
    # 3x the source plus 0.5 GB for the outputs and the runtime.
    src_bytes = 16384 * 8192 * 3 * 4
    proc = subprocess.Popen([sys.executable, "-c", BAKE_BIG], stdout=subprocess.PIPE,
                            env=dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p)))
    out = proc.stdout.read()
    _, status, usage = os.wait4(proc.pid, 0)
    assert status == 0
    result = json.loads(out)
    assert result["finite"]
    assert result["irr_min"] > 0.4
    peak = usage.ru_maxrss * 1024
    print(f"16384 x 8192: peak RSS {peak / 2**30:.2f} GB for a {src_bytes / 2**30:.2f} GB source")
    assert peak < 3 * src_bytes + 0.5 * 2**30
