"""Input checks: a bad value names the parameter and the allowed range."""
import pytest

from uavwind.core.checks import check_scalar


def test_check_scalar_message_names_range():
    with pytest.raises(ValueError, match=r"alpha must be in \[0.0, 1.0\]|alpha must be in \[0, 1\]"):
        check_scalar(2.0, "alpha", low=0, high=1)
