"""A run's span (h with one of t_end and n_steps) is reconciled in one place (raydamp._validation.span):
raydamp.integrate, a job's JSON (raydamp.jobs.planned_steps, which the service's step limit counts with)
and a sweep's save grid count the same steps and say the same thing when the span is wrong."""

from __future__ import annotations

import pytest

import raydamp
from raydamp.jobs import JobError, parse_job, planned_steps
from raydamp.models import DampedPendulum

JOB = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "h": 0.3, "t_end": 1.0,
       "initial_state": {"q": [1.0], "p": [0.0]}}


def test_a_job_counts_the_steps_integrate_takes():
    # 1.0 / 0.3 = 3.33: four steps, the last shortened to 0.1 so that the run ends on t_end exactly.
    sol = raydamp.integrate(DampedPendulum(eps=0.01), [1.0], [0.0], method="3s", h=0.3, t_end=1.0)
    assert planned_steps(parse_job(JOB)) == sol.steps == 4
    assert sol.t[-1] == pytest.approx(1.0, abs=1e-15)
    # within 1e-9 relative of a whole multiple: whole steps, as raydamp.steps_for says
    assert planned_steps(parse_job({**JOB, "h": 0.1, "t_end": 0.1 * 7 * (1 + 1e-12)})) == 7


@pytest.mark.parametrize(("change", "loc", "message"), [
    ({"n_steps": 5}, ("n_steps",), "n_steps: give exactly one of t_end and n_steps, not both"),
    ({"t_end": None}, ("t_end",), "t_end: give exactly one of t_end and n_steps"),
    ({"t_end": 1e300, "h": 1e-300}, ("t_end",), "t_end: reaching t_end = 1e+300 with h = 1e-300"),
])
def test_a_wrong_span_is_the_same_error_in_a_job_and_in_integrate(change, loc, message):
    job = {k: v for k, v in {**JOB, **change}.items() if v is not None}
    with pytest.raises(JobError) as caught:
        planned_steps(parse_job(job))
    assert caught.value.loc == loc and str(caught.value).startswith(message)
    with pytest.raises(ValueError) as direct:
        raydamp.integrate(DampedPendulum(eps=0.01), [1.0], [0.0], method="3s", h=job["h"], t_end=job.get("t_end"),
                          n_steps=job.get("n_steps"))
    assert str(direct.value) == str(caught.value)

