"""Finds the built module: PYTHONPATH from CTest, else build/native."""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_BUILD = os.path.abspath(os.path.join(HERE, "..", "..", "build", "native"))
if DEFAULT_BUILD not in sys.path and not os.environ.get("PYTHONPATH"):
    sys.path.insert(0, DEFAULT_BUILD)
