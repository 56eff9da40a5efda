"""Recursive Bayesian hypothesis recognition and parameter estimation (paper 002) and its performance criteria."""

from .bank import BankResult, BankSnapshot, HypothesisBank, HypothesisEstimate
from .model import COMPONENT_PARAMETERS, Hypothesis, HypothesisSet, ParameterPrior, averaged_dynamic_block

__all__ = [
    "COMPONENT_PARAMETERS",
    "BankResult",
    "BankSnapshot",
    "Hypothesis",
    "HypothesisBank",
    "HypothesisEstimate",
    "HypothesisSet",
    "ParameterPrior",
    "averaged_dynamic_block",
]
