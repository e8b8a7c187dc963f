"""Finds the compiled iblbake_core module.

Looked for, in order: inside the add-on package (the packaged zip), in
$IBLBAKE_CORE_DIR, in a source checkout's build/native (developer install),
then on sys.path."""
import importlib
import os
import sys
from pathlib import Path

_PACKAGE = __package__.rsplit(".", 1)[0]  # "iblbake" (or bl_ext.*.iblbake)
_HINT = ("iblbake's native module (iblbake_core) was not found: build it with "
         "`bash scripts/build.sh`, or install the add-on zip made by "
         "`cmake --build build --target addon_zip`")


def _candidates():
    env = os.environ.get("IBLBAKE_CORE_DIR")
    if env:
        yield Path(env)
    here = Path(__file__).resolve()
    for parent in here.parents[1:4]:  # addon/iblbake -> addon -> checkout
        yield parent / "build" / "native"


def load():
    try:
        return importlib.import_module(_PACKAGE + ".iblbake_core")
    except ImportError:
        pass
    for folder in _candidates():
        if any(folder.glob("iblbake_core*.so")):
            if str(folder) not in sys.path:
                sys.path.insert(0, str(folder))
            break
    try:
        return importlib.import_module("iblbake_core")
    except ImportError as e:
        raise ImportError(_HINT + " (" + str(e) + ")") from e
