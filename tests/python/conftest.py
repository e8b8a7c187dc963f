"""Finds the built module: PYTHONPATH from CTest, else build/native."""
import importlib.machinery
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_BUILD = os.path.join(HERE, "..", "..", "build", "native")
MODULE = "iblbake_core" + importlib.machinery.EXTENSION_SUFFIXES[0]  # for this Python
if not any(os.path.exists(os.path.join(p, MODULE)) for p in sys.path if p):
    sys.path.insert(0, os.path.abspath(DEFAULT_BUILD))
