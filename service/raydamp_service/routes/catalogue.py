"""GET /v1/models, /v1/methods, /v1/structure_methods, /v1/compositions: what a job may ask for (raydamp's)."""

from __future__ import annotations

from fastapi import APIRouter

import raydamp
from raydamp.methods.catalogue import structure_methods
from raydamp.models import describe_models

from ..schemas import CompositionInfo, MethodInfo, ModelInfo

router = APIRouter(prefix="/v1", tags=["catalogue"])


@router.get("/models", response_model=list[ModelInfo])
def list_models() -> list[ModelInfo]:
    """Every model with its dimension, momentum maps, and parameters with their defaults."""
    return [ModelInfo.model_validate(model) for model in describe_models()]


@router.get("/methods", response_model=list[MethodInfo])
def list_methods() -> list[MethodInfo]:
    """Every usable (method, tableau) pair with its order."""
    return [MethodInfo.model_validate(method._asdict()) for method in raydamp.methods()]


@router.get("/structure_methods", response_model=list[MethodInfo])
def list_structure_methods() -> list[MethodInfo]:
    """The methods that run only a structure with springs ({"kind": "structure", "springs": [...]}): newmark,
    Newmark's average acceleration with Newton's iteration on the springs, as OpenSees runs it. A job naming one
    on any other system is refused (422 at `method`); a step that does not converge ends the job's run with
    status not_converged, naming the step, its rows kept."""
    return [MethodInfo.model_validate(method._asdict()) for method in structure_methods()]


@router.get("/compositions", response_model=list[CompositionInfo])
def list_compositions() -> list[CompositionInfo]:
    """Every composition a job's `composition` may name, for the symmetric methods (GET /v1/methods)."""
    return [CompositionInfo.model_validate(composition._asdict()) for composition in raydamp.compositions()]
