"""bench/report.py regenerates docs/benchmarks.md; the hand-written sections
between its markers (issue 14's side-by-side timings) must survive that."""
import os
import sys

import pytest

ROOT = os.path.join(os.path.dirname(__file__), "..", "..")
sys.path.insert(0, os.path.join(ROOT, "bench"))
pytest.importorskip("matplotlib")  # bench's group of scripts/install_deps.sh
import report  # noqa: E402


def test_kept_sections_are_carried_over_whole_and_in_order():
    page = ("# old page\nintro\n" + report.KEEP_BEGIN + "\n## A\nfigures a\n" + report.KEEP_END +
            "\n## generated\nstale numbers\n" + report.KEEP_BEGIN + "\n## B\n" + report.KEEP_END + "\ntail\n")
    kept = report.kept_sections(page)
    assert kept == [report.KEEP_BEGIN + "\n## A\nfigures a\n" + report.KEEP_END + "\n",
                    report.KEEP_BEGIN + "\n## B\n" + report.KEEP_END + "\n"]
    assert report.kept_sections("# no markers\n") == []
    with pytest.raises(ValueError):
        report.kept_sections(report.KEEP_BEGIN + "\n## unterminated\n")


def test_the_issue_14_section_of_the_page_is_marked_to_be_kept():
    with open(os.path.join(ROOT, "docs", "benchmarks.md")) as f:
        kept = report.kept_sections(f.read())
    assert any("## Issue 14" in k for k in kept)
