"""Bad input to raydamp.Structure and its springs: each error names the argument or the JSON path."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

import raydamp
from raydamp.jobs import JobSpec, client_path, job_arguments
from raydamp.materials import Bilinear, BoucWen, ElasticPlastic


@pytest.mark.parametrize(("make", "message"), [
    (lambda: ElasticPlastic(10.0, 0.0), "material.fy: the yield force must be > 0"),
    (lambda: ElasticPlastic(10.0, -1.0), "material.fy"),
    (lambda: Bilinear(-1.0, 1.0, 0.1), "material.k"),
    (lambda: Bilinear(10.0, 1.0, 1.0), "material.b: the post-yield stiffness ratio must be in [0, 1)"),
    (lambda: Bilinear(10.0, 1.0, -1.0), "material.b"),
    (lambda: BoucWen(10.0, 1.0, 0.1, beta=-0.5), "material.beta: the hysteresis is bounded only"),
    (lambda: BoucWen(10.0, 1.0, 0.1, beta=0.5, gamma=-0.6), "material.gamma: the hysteresis is bounded only"),
    (lambda: BoucWen(10.0, 1.0, 0.1, n=2), "material.n: only n = 1"),
    (lambda: BoucWen(10.0, 1.0, 1.0), "material.alpha"),
])
def test_a_bad_material_names_its_parameter(make, message):
    with pytest.raises(ValueError) as caught:
        make()
    assert str(caught.value).startswith(message), str(caught.value)


def test_a_softening_bilinear_is_allowed():
    assert Bilinear(10.0, 1.0, -0.5).b == -0.5


@pytest.mark.parametrize(("M", "springs", "message"), [
    (np.eye(3), [raydamp.Spring((0, 5), ElasticPlastic(1, 1))], "springs[0].dofs: coordinate 5 outside 0..2"),
    (np.eye(3), [raydamp.Spring((0,), ElasticPlastic(1, 1)), raydamp.Spring((-1,), ElasticPlastic(1, 1))],
     "springs[1].dofs: coordinate -1 outside"),
    (np.diag([1.0, 0.0, 1.0]), [raydamp.Spring((0, 1), ElasticPlastic(1, 1))],
     "springs[0].dofs: coordinate 1 has no mass"),
    (np.eye(3), [ElasticPlastic(1, 1)], "springs[0]: expected a raydamp.Spring"),
])
def test_a_bad_spring_names_its_index(M, springs, message):
    with pytest.raises(ValueError) as caught:
        raydamp.Structure(M, springs=springs)
    assert str(caught.value).startswith(message), str(caught.value)


def test_a_spring_refuses_the_same_coordinate_twice():
    with pytest.raises(ValueError, match=r"^dofs: the two coordinates are the same"):
        raydamp.Spring((1, 1), ElasticPlastic(1, 1))


def frame_dict(changes=None):
    structure = raydamp.Structure(np.diag([1.0, 1.0]), springs=[
        raydamp.Spring((0,), Bilinear(20.0, 1.0, 0.05)), raydamp.Spring((0, 1), BoucWen(10.0, 0.5, 0.1))],
        alpha=0.1)
    plain = structure.to_dict()
    for path, value in (changes or {}).items():
        target = plain
        *head, last = path
        for key in head:
            target = target[key]
        target[last] = value
    return plain


def test_the_plain_form_round_trips_and_runs_as_a_job():
    plain = frame_dict()
    assert plain["kind"] == "structure" and len(plain["springs"]) == 2
    again = raydamp.Structure.from_dict(plain)
    assert again.to_dict() == plain
    load = raydamp.Load.harmonic([5.0, 5.0], 3.0, t_end=1.0)
    job = {"system": plain, "method": "3s", "h": 0.01, "n_steps": 200,
           "initial_state": {"q": [0.0, 0.0], "p": [0.0, 0.0]}, "load": load.to_dict()}
    model, q0, p0, options = job_arguments(job)
    from_job = raydamp.integrate(model, q0, p0, **options)
    direct = raydamp.integrate(again, [0, 0], [0, 0], method="3s", h=0.01, n_steps=200, load=load)
    np.testing.assert_array_equal(from_job.q, direct.q)


@pytest.mark.parametrize(("change", "path"), [
    ({("springs", 0, "material", "fy"): 0.0}, ("system", "springs", 0, "material", "fy")),
    ({("springs", 0, "material", "b"): 1.0}, ("system", "springs", 0, "material", "b")),
    ({("springs", 1, "material", "beta"): -1.0}, ("system", "springs", 1, "material", "beta")),
    ({("springs", 1, "material", "kind"): "steel02"}, ("system", "springs", 1, "material")),
])
def test_a_bad_spring_in_json_is_a_422_at_its_path(change, path):
    job = {"system": frame_dict(change), "method": "3s", "h": 0.01, "n_steps": 10,
           "initial_state": {"q": [0.0, 0.0], "p": [0.0, 0.0]}}
    with pytest.raises(ValidationError) as caught:
        JobSpec.model_validate(job)
    paths = [client_path(e["loc"]) for e in caught.value.errors()]
    assert path in paths, paths


@pytest.mark.parametrize(("change", "message"), [
    ({("springs", 1, "dofs"): [0, 4]}, "system.springs[1].dofs: coordinate 4 outside 0..1"),
    ({("springs", 1, "material", "gamma"): -0.7}, "system.springs[1].material.gamma: the hysteresis is bounded"),
])
def test_a_bad_spring_found_when_built_names_its_path(change, message):
    job = {"system": frame_dict(change), "method": "3s", "h": 0.01, "n_steps": 10,
           "initial_state": {"q": [0.0, 0.0], "p": [0.0, 0.0]}}
    from raydamp.jobs import JobError

    with pytest.raises(JobError) as caught:
        job_arguments(job)
    assert str(caught.value).startswith(message), str(caught.value)
    assert caught.value.loc[:3] == ("system", "springs", 1)


def test_a_pulse_is_a_harmonic_term_with_an_end():
    load = raydamp.Load.harmonic([2.0], 5.0, t_end=0.6)
    again = raydamp.Load.from_dict(load.to_dict())
    assert again.to_dict() == load.to_dict() and load.to_dict()["terms"][0]["harmonic"]["t_end"] == 0.6
    model = raydamp.LinearStructure(np.eye(1), np.eye(1))
    values = load.values(model, [0.3, 0.6, 0.61, 2.0])[:, 0]
    np.testing.assert_allclose(values, [2 * np.sin(1.5), 2 * np.sin(3.0), 0.0, 0.0], rtol=0, atol=1e-15)
    with pytest.raises(ValueError, match="^t_end"):
        raydamp.Load.harmonic([2.0], 5.0, t_end=float("nan"))


def test_events_on_springs_watch_but_a_terminal_one_is_refused():
    """A terminal event shortens the last step by running it again from its start, which the springs' committed
    state cannot do yet: refused naming events[i].terminal; a watching event finds the yield crossing."""
    s = raydamp.Structure(np.eye(1), springs=[raydamp.Spring((0,), ElasticPlastic(10.0, 7.5))], alpha=0.1)
    with pytest.raises(ValueError, match=r"^events\[1\]\.terminal: a terminal event on a Structure with springs"):
        raydamp.integrate(s, [0.0], [10.0], method="3s", h=0.01, t_end=1.0,
                          events=[raydamp.Event("q[0]"), raydamp.Event("q[0] - 0.5", terminal=True)])
    sol = raydamp.integrate(s, [0.0], [10.0], method="3s", h=1e-3, t_end=1.0,
                            events=[raydamp.Event("q[0] - 0.5", direction=1, name="half")])
    # elastic up to q = 0.75 (fy / k): from rest at q = 0 with p = 10 (m = 1, k = 10, light damping) q = 0.5 is
    # crossed once, on the way up, at t ~ asin(0.5 / (10 / sqrt(10))) / sqrt(10) (the damping shifts it a little)
    crossings = sol.events["half"].t
    assert len(crossings) == 1
    assert abs(crossings[0] - np.arcsin(0.5 / np.sqrt(10.0)) / np.sqrt(10.0)) < 5e-3
