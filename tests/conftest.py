"""Shared fixtures: models that are expensive to derive are built once per session."""

import pytest

import kanedyn as kd


@pytest.fixture(scope="session")
def bicycle():
    """(definition, eom, numeric model) of the Whipple bicycle, benchmark parameters."""
    definition = kd.models.build("whipple-bicycle")
    eom = definition.derive()
    return definition, eom, definition.numeric(eom)
