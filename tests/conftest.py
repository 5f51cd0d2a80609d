"""Fixtures shared by the numerical tests."""

import pytest


@pytest.fixture(params=["damped_pendulum", "elastic_pendulum"])
def model_name(request) -> str:
    return request.param
