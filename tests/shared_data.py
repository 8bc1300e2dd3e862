"""../shared beside the repository: the real recordings and the interpreters' sources.

CI always has it; a checkout without it skips, with one line saying why, the
tests that need it.
"""

import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")


def need_shared(*parts):
    """The path ../shared/PARTS, or skip the test saying that it needs it."""
    path = os.path.join(SHARED, *parts)
    if not os.path.exists(path):
        pytest.skip("needs %s (../shared beside the repository, as in CI)" % path)
    return path
