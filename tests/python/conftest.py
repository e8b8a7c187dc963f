"""Finds the built module: PYTHONPATH from CTest, else build/native."""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_BUILD = os.path.join(HERE, "..", "..", "build", "native")
if not any(os.path.exists(os.path.join(p, "iblbake_core.cpython-311-x86_64-linux-gnu.so")) for p in sys.path if p):
    sys.path.insert(0, os.path.abspath(DEFAULT_BUILD))
