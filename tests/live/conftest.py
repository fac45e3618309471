"""Fixtures of the live tests."""

from __future__ import annotations

import pytest

from roadgrip.io.can import SHIPPED_DBC, SHIPPED_MAP, load_dbc, load_signal_map


@pytest.fixture(scope="session")
def codec():
    """The shipped DBC and its signal map."""
    return load_dbc(SHIPPED_DBC), load_signal_map(SHIPPED_MAP)
