"""Conformance suite: `spectratac conformance URL` against any SpectraTac device."""

from spectratac.conformance.checks import CHECKS, Outcome, run_check
from spectratac.conformance.model_checks import MODEL_CHECKS, ModelSession, TestModel
from spectratac.conformance.suite import SuiteResult, run_suite

__all__ = [
    "CHECKS",
    "MODEL_CHECKS",
    "ModelSession",
    "Outcome",
    "SuiteResult",
    "TestModel",
    "run_check",
    "run_suite",
]
