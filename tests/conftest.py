"""Shared fixtures: paths of the shipped models and the reference data."""

import json
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MODELS = ROOT / "models"
REFERENCE = Path(__file__).resolve().parent / "reference"


@pytest.fixture(scope="session")
def slider_crank_reference():
    """Independent reference solutions of the rigid slider crank (provenance in the file)."""
    return json.loads((REFERENCE / "slider_crank.json").read_text())
