"""The service's estimate of a job's stored trajectory (max_trajectory_bytes) counts what the store keeps:
t, energy, W (a job with work), W_f (a job with work and a load: a review found it left out), q, p and
the momentum maps per saved point. Checked at the limit's boundary, in-process (problems.check_spec), and
against what a run of the job really stores."""

from __future__ import annotations

import pytest

from raydamp.jobs import JobError, JobSpec
from raydamp_service.checks.limits import check_spec
from raydamp_service.config import Settings
from raydamp_service.kinds.jobs import StoredTrajectory

STEPS = 1000
PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.1}, "method": "3s", "h": 0.1, "n_steps": STEPS,
            "initial_state": {"q": [0.5], "p": [0.0]}}
FORCED = {**PENDULUM, "load": {"harmonic": {"amplitude": [0.2], "omega": 1.1}}}
# The points a run saves (raydamp.run.save_rows: step 0 and every step), of 1 coordinate and no momentum map:
# t, energy, W, W_f, q, p with the load; W_f left out without it, W too with "work": false. The estimate once
# counted n_steps // save_every + 2, a point more than a run saves when save_every divides n_steps.
POINTS = STEPS + 1


def admitted(spec: dict, limit: int) -> bool:
    try:
        check_spec(JobSpec.model_validate(spec), Settings(max_trajectory_bytes=limit))
    except JobError as error:
        assert error.loc == ("save_every",) and "max_trajectory_bytes" in str(error), error
        return False
    return True


@pytest.mark.parametrize(("spec", "columns"), [(FORCED, 6), (PENDULUM, 5), ({**FORCED, "work": False}, 4)])
def test_the_limit_admits_exactly_the_bytes_a_job_stores(spec, columns):
    need = POINTS * columns * 8
    assert admitted(spec, need)
    assert not admitted(spec, need - 1)


@pytest.mark.parametrize(("spec", "columns"), [(FORCED, 6), (PENDULUM, 5), ({**FORCED, "work": False}, 4)])
def test_the_columns_counted_are_those_the_run_stores(spec, columns):
    """The run's arrays as the store keeps them (jobs.StoredTrajectory: W and W_f when not None), and its
    points: exactly the estimate's."""
    solution = check_spec(JobSpec.model_validate(spec), Settings()).run()
    stored = StoredTrajectory.of(solution)
    assert stored.row_bytes == columns * 8
    assert stored.points == POINTS
