"""The compat module refuses unsupported DOLFINx versions with a clear message."""

import pytest

from dgplate import compat
from dgplate.errors import UnsupportedVersionError


def test_current_version_supported():
    assert compat.DOLFINX_VERSION >= (0, 9)
    compat.require_supported_version()


@pytest.mark.parametrize("old", [(0, 5), (0, 8)])
def test_old_version_refused(old):
    with pytest.raises(UnsupportedVersionError, match=r"DOLFINx 0\.[58] is not supported"):
        compat.require_supported_version(old)
