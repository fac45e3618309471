"""Fixtures of the live tests."""

from __future__ import annotations

import pytest

from roadgrip.live.replay import shipped_codec


@pytest.fixture(scope="session")
def codec():
    """The shipped DBC and its signal map."""
    return shipped_codec()
