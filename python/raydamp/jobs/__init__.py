"""The job: one JSON form of a run for the service, ``raydamp run``, sweeps and every Solution's
provenance. Pydantic models validate it (errors name the JSON path), and ``build_job`` turns it
into raydamp.integrate's arguments.

    {"model": "elastic_pendulum", "parameters": {"eps": 0.1}}   or   {"system": System.to_dict()}
    + {"method": "3s", "tableau": null, "composition": null, "h": 0.1, "t_end": 100 | "n_steps": 1000,
       "save_every": 1, "initial_state": {"q": [...], "p": [...]} (or {"file": id} each), "work": true}
"""

from ..loads.forms import GroundMotionInput, LoadInput
from ..systems.kinds import describe_model
from .build import (
                    PROVENANCE_KEYS,
                    JobCall,
                    build_job,
                    error_at,
                    job_arguments,
                    model_from_spec,
                    parse_job,
                    planned_steps,
                    validation_error,
)
from .errors import JobError
from .forms import InitialState, ModeState, RestState, TableauInput, VectorFile
from .spec import STEP_SIZE_ALIAS, UNION_TAGS, JobSpec, ModelSpec, client_path
from .summary import JobSummary
from .sweep_spec import GridRange, SweepSpec
from .system_forms import (
                    ChainInput,
                    CooForm,
                    DiagonalForm,
                    FileForm,
                    KeplerInput,
                    LinearStructureInput,
                    PlanetsInput,
                    SystemInput,
)

__all__ = ["JobSpec", "JobSummary", "ModelSpec", "SweepSpec", "GridRange", "JobError", "JobCall", "parse_job",
           "build_job", "planned_steps", "error_at", "job_arguments", "validation_error", "client_path",
           "describe_model", "model_from_spec", "PROVENANCE_KEYS", "STEP_SIZE_ALIAS", "UNION_TAGS", "InitialState",
           "ModeState", "RestState", "TableauInput", "SystemInput", "ChainInput", "KeplerInput", "PlanetsInput",
           "LinearStructureInput", "CooForm", "DiagonalForm", "FileForm", "VectorFile", "LoadInput",
           "GroundMotionInput"]
