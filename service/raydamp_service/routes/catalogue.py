"""GET /v1/models and /v1/methods: what a job may ask for, read from raydamp's own catalogue."""

from __future__ import annotations

import raydamp
from fastapi import APIRouter
from raydamp.models import describe_models

from ..schemas import MethodInfo, ModelInfo

router = APIRouter(prefix="/v1", tags=["catalogue"])


@router.get("/models", response_model=list[ModelInfo])
def list_models() -> list[ModelInfo]:
    """Every model with its dimension, momentum maps, and parameters with their defaults."""
    return [ModelInfo.model_validate(model) for model in describe_models()]


@router.get("/methods", response_model=list[MethodInfo])
def list_methods() -> list[MethodInfo]:
    """Every usable (method, tableau) pair with its order."""
    return [MethodInfo.model_validate(method._asdict()) for method in raydamp.methods()]
