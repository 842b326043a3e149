"""Conformance suite: `spectratac conformance URL` against any SpectraTac device."""

from spectratac.conformance.checks import CHECKS, Outcome, run_check
from spectratac.conformance.suite import SuiteResult, run_suite

__all__ = ["CHECKS", "Outcome", "SuiteResult", "run_check", "run_suite"]
