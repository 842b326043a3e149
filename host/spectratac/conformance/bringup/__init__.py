"""`spectratac bringup URL`: the bring-up plan for a new board as a command, with a report
(text or JSON) a person files with the board ([README](README.md))."""

from spectratac.conformance.bringup.report import FAIL, PASS, SKIPPED, Report, Row, is_report
from spectratac.conformance.bringup.runner import SOAK_S, plan, run_bringup

__all__ = ["FAIL", "PASS", "SKIPPED", "SOAK_S", "Report", "Row", "is_report", "plan", "run_bringup"]
