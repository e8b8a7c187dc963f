"""Finds the built module: PYTHONPATH from CTest, else build/native."""
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_BUILD = os.path.abspath(os.path.join(HERE, "..", "..", "build", "native"))
if DEFAULT_BUILD not in sys.path and not os.environ.get("PYTHONPATH"):
    sys.path.insert(0, DEFAULT_BUILD)


def pytest_terminal_summary(terminalreporter):
    """The corpus's counts, also when pytest captures output (CTest)."""
    mod = sys.modules.get("test_corpus")
    if mod is None or not mod.STATS["cases"]:
        return
    s = dict(mod.STATS, peak_mb=round(mod.STATS["peak_kb"] / 1024, 1))
    terminalreporter.write_line(
        "hostile corpus: %(cases)d cases, %(errors)d clear one-line errors, %(baked)d bakes "
        "(%(repairs_counted)d with counted repairs, %(warned)d with warnings), crashes %(crashes)d, hangs %(hangs)d, "
        "NaN %(nan)d, lost files %(lost_bakes)d, wrong results at exit 0 %(wrong)d, peak memory %(peak_mb)s MB "
        "(%(peak_case)s), skipped %(skipped)d" % s)
