"""Helpers the Mitsuba test files share (python/tests, imported beside them): whether Dr.Jit's
LLVM backend can render here, and the JSON report of figures CI prints."""

import json
import os
import subprocess
import sys
from pathlib import Path

_llvm = {}


def llvm_status():
    """(works, why not): renders a tiny scene with the LLVM backend in a child process, since
    an LLVM too old for Dr.Jit aborts the process (LLVM 15: 'Cannot select ... fminimum')."""
    if "status" not in _llvm:
        code = (
            "import drjit as dr, mitsuba as mi\n"
            "assert dr.has_backend(dr.JitBackend.LLVM), 'no LLVM backend found'\n"
            "mi.set_variant('llvm_ad_rgb')\n"
            "s = mi.load_dict({'type': 'scene', 'i': {'type': 'path'}, 's': {'type': 'sphere'},"
            " 'e': {'type': 'constant'}, 'c': {'type': 'perspective',"
            " 'film': {'type': 'hdrfilm', 'width': 4, 'height': 4}}})\n"
            "import numpy as np\n"
            "print(float(np.mean(np.array(mi.render(s)))))\n"
        )
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=300)
        if done.returncode == 0:
            _llvm["status"] = (True, "")
        else:
            tail = (done.stderr.strip().splitlines() or ["(no message)"])[-1][:200]
            _llvm["status"] = (False, f"Dr.Jit's LLVM backend cannot render here (exit "
                                      f"{done.returncode}: {tail}); install libllvm19")
    return _llvm["status"]


def record(key, value):
    """Adds `key: value` to the JSON report named by $SBRDF_MITSUBA_REPORT, if set."""
    report = os.environ.get("SBRDF_MITSUBA_REPORT")
    if not report:
        return
    data = json.loads(Path(report).read_text()) if Path(report).exists() else {}
    data[key] = value
    Path(report).write_text(json.dumps(data, indent=1, sort_keys=True))
