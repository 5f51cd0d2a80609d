"""Bad specs get 422 with detail[].loc naming the JSON field, before anything is queued."""

from __future__ import annotations

import json
import math

import pytest

VALID = {
    "model": "damped_pendulum", "parameters": {"eps": 0.01}, "method": "3s", "step_size": 0.2, "t_end": 200,
    "initial_state": {"q": [0.9 * math.pi], "p": [0.0]},
}
ELASTIC = {**VALID, "model": "elastic_pendulum", "parameters": {},
           "initial_state": {"q": [0.0, 1.55884573, -0.6], "p": [1.34164079, 0.0, 0.0]}}


def without(spec: dict, *keys: str) -> dict:
    return {k: v for k, v in spec.items() if k not in keys}


# (case, spec, the field its 422 must name). The module's server allows 10^10 steps.
BAD_SPECS = [
    ("negative step_size", {**VALID, "step_size": -0.2}, ("step_size",)),
    ("zero step_size", {**VALID, "step_size": 0}, ("step_size",)),
    ("step_size as a string", {**VALID, "step_size": "0.2"}, ("step_size",)),
    ("both t_end and n_steps", {**VALID, "n_steps": 1000}, ("n_steps",)),
    ("neither t_end nor n_steps", without(VALID, "t_end"), ("t_end",)),
    ("negative t_end", {**VALID, "t_end": -1}, ("t_end",)),
    ("zero n_steps", {**without(VALID, "t_end"), "n_steps": 0}, ("n_steps",)),
    ("fractional n_steps", {**without(VALID, "t_end"), "n_steps": 10.5}, ("n_steps",)),
    ("zero save_every", {**VALID, "save_every": 0}, ("save_every",)),
    # Before min_length 1 the run saved every coordinate while its dofs said none: its NetCDF failed.
    ("empty save_dofs", {**VALID, "save_dofs": []}, ("save_dofs",)),
    ("unknown model", {**VALID, "model": "double_pendulum"}, ("model",)),
    ("unknown method", {**VALID, "method": "leapfrog"}, ("method",)),
    ("unknown tableau", {**VALID, "method": "rks", "tableau": "dopri5"}, ("tableau",)),
    ("tableau for a pure splitting", {**VALID, "tableau": "rk4"}, ("tableau",)),
    ("implicit tableau for rksb", {**VALID, "method": "rksb", "tableau": "midpoint"}, ("tableau",)),
    ("sv with damping", {**VALID, "method": "sv"}, ("method",)),
    ("unknown composition", {**VALID, "composition": "yoshida6"}, ("composition",)),
    ("composition over a non-symmetric method", {**VALID, "method": "heun", "composition": "yoshida4"},
     ("composition",)),
    ("composition past the amplification guard", {**VALID, "parameters": {"eps": 100.0}, "method": "2s",
                                                   "composition": "yoshida4"}, ("composition",)),
    ("wrong q length", {**VALID, "initial_state": {"q": [1.0, 2.0], "p": [0.0]}}, ("initial_state", "q")),
    ("wrong p length", {**ELASTIC, "initial_state": {"q": [0.0, 1.0, 0.0], "p": [1.0]}}, ("initial_state", "p")),
    ("empty q", {**VALID, "initial_state": {"q": [], "p": [0.0]}}, ("initial_state", "q")),
    ("q beyond max_dim", {**VALID, "initial_state": {"q": [0.0] * 1001, "p": [0.0]}}, ("initial_state", "q")),
    ("missing initial_state", without(VALID, "initial_state"), ("initial_state",)),
    ("unknown extra field", {**VALID, "stepsize": 0.1}, ("stepsize",)),
    ("unknown field in initial_state", {**VALID, "initial_state": {"q": [1.0], "p": [0.0], "t": 0}},
     ("initial_state", "t")),
    ("negative eps", {**VALID, "parameters": {"eps": -0.01}}, ("parameters", "eps")),
    ("eps as a vector", {**VALID, "parameters": {"eps": [0.01]}}, ("parameters", "eps")),
    ("unknown parameter", {**VALID, "parameters": {"eps": 0.01, "mass": 2.0}}, ("parameters", "mass")),
    ("zero mass", {**ELASTIC, "parameters": {"m": 0.0}}, ("parameters", "m")),
    ("gravity of the wrong length", {**ELASTIC, "parameters": {"g": [0.0, -1.0]}}, ("parameters", "g")),
    ("too many steps", {**without(VALID, "t_end"), "n_steps": 10**10 + 1, "save_every": 10**6}, ("n_steps",)),
    ("too long a t_end", {**VALID, "t_end": 1e300, "save_every": 10**6}, ("t_end",)),
    ("too many saved points", {**without(VALID, "t_end"), "n_steps": 10**7}, ("save_every",)),
    ("save_every beyond a C++ long", {**VALID, "save_every": 10**20}, ("save_every",)),
    ("fully implicit user tableau", {**VALID, "method": "rks", "tableau": {
        "A": [[0.25, -0.0386751345948129], [0.5386751345948129, 0.25]], "b": [0.5, 0.5],
        "c": [0.2113248654051871, 0.7886751345948129]}}, ("tableau",)),
    ("user tableau whose rows miss c", {**VALID, "method": "rk", "tableau": {
        "A": [[0, 0], [0.6, 0]], "b": [0.5, 0.5], "c": [0, 1]}}, ("tableau",)),
    ("user tableau claiming too high an order", {**VALID, "method": "rk", "tableau": {
        "A": [[0, 0], [1, 0]], "b": [0.5, 0.5], "c": [0, 1], "order": 3}}, ("tableau",)),
    ("user tableau with a string coefficient", {**VALID, "method": "rk", "tableau": {
        "A": [[0, 0], ["1", 0]], "b": [0.5, 0.5], "c": [0, 1]}}, ("tableau",)),
    ("elastic pendulum at the origin", {**ELASTIC, "initial_state": {"q": [0.0, 0.0, 0.0], "p": [1.0, 0.0, 0.0]}},
     ("initial_state", "q")),
]

NON_FINITE = [
    ("NaN step_size", {**VALID, "step_size": math.nan}, ("step_size",)),
    ("infinite t_end", {**VALID, "t_end": math.inf}, ("t_end",)),
    ("infinite q", {**VALID, "initial_state": {"q": [-math.inf], "p": [0.0]}}, ("initial_state", "q", 0)),
    ("NaN parameter", {**VALID, "parameters": {"eps": math.nan}}, ("parameters", "eps")),
]


def assert_names(response, field: tuple) -> None:
    assert response.status_code == 422, response.text
    locs = [tuple(error["loc"]) for error in response.json()["detail"]]
    assert any(loc[:len(field) + 1] == ("body", *field) for loc in locs), locs
    assert all(error["msg"] for error in response.json()["detail"])


@pytest.mark.parametrize(("spec", "field"), [case[1:] for case in BAD_SPECS], ids=[case[0] for case in BAD_SPECS])
def test_bad_spec_is_422_naming_the_field(server, spec, field):
    assert_names(server.client.post("/v1/jobs", json=spec), field)


@pytest.mark.parametrize(("spec", "field"), [case[1:] for case in NON_FINITE], ids=[case[0] for case in NON_FINITE])
def test_nan_and_infinity_are_422(server, spec, field):
    # Python's JSON parser (the server's too) reads NaN and Infinity; they must not reach a run.
    body = json.dumps(spec, allow_nan=True)
    assert_names(server.client.post("/v1/jobs", content=body, headers={"content-type": "application/json"}), field)


def test_overflowing_number_is_422(server):
    body = json.dumps(VALID).replace('"step_size": 0.2', '"step_size": 1e999')
    assert_names(server.client.post("/v1/jobs", content=body, headers={"content-type": "application/json"}),
                 ("step_size",))


@pytest.mark.parametrize("body", [b'{"model": "damped_pendulum",', b"not json", b"[1, 2]", b"",
                                  # a 400 without a loc before, as FastAPI answers what json.loads refuses
                                  # other than by a JSONDecodeError
                                  b"[" * 5000 + b"]" * 5000, b'{"model": "\xff"}',
                                  b'{"n_steps": ' + b"9" * 5001 + b"}"])  # over Python's 4300 digits (an audit)
def test_malformed_body_is_422(server, body):
    response = server.client.post("/v1/jobs", content=body, headers={"content-type": "application/json"})
    assert response.status_code == 422, response.text
    assert response.json()["detail"][0]["loc"][0] == "body"


@pytest.mark.parametrize("where", ["job", "initial_state"])
def test_a_flood_of_unknown_keys_is_one_422(server, where):
    """Each unknown key was an error of its own, built, converted and encoded on the event loop with the whole
    body as the input of another error: 160,000 keys held /healthz for 2 s (an audit). One error now."""
    flood = {f"k{i}": 0 for i in range(100_000)}
    spec = {**VALID, **flood} if where == "job" else {**VALID, "initial_state": {**VALID["initial_state"], **flood}}
    response = server.client.post("/v1/jobs", json=spec)
    assert response.status_code == 422, response.text[:300]
    detail = response.json()["detail"]
    assert len(detail) == 1 and "100000 unknown keys ('k0', 'k1', 'k2', ...)" in detail[0]["msg"], detail
    assert detail[0]["loc"] == (["body"] if where == "job" else ["body", "initial_state"]), detail
    assert len(response.content) < 10_000  # its input is cut short, not the body echoed


def test_domain_errors_speak_in_json_field_names(server):
    detail = server.client.post("/v1/jobs", json={**VALID, "initial_state": {"q": [1.0, 2.0], "p": [0.0]}}).json()
    assert detail["detail"][0]["msg"].startswith("initial_state.q ")  # raydamp calls it q0


def test_nothing_invalid_was_queued(server):
    for case in BAD_SPECS:
        server.client.post("/v1/jobs", json=case[1])
    assert server.client.get("/v1/jobs").json()["jobs"] == []


def test_a_user_tableau_runs_as_in_python(server):
    """Kutta's third-order tableau on the whole system: the job's final state is raydamp's."""
    import raydamp
    from raydamp.models import DampedPendulum

    kutta3 = {"A": [[0, 0, 0], [0.5, 0, 0], [-1, 2, 0]], "b": [1 / 6, 2 / 3, 1 / 6], "c": [0, 0.5, 1], "order": 3}
    job_id = server.submit({**VALID, "method": "rk", "tableau": kutta3, "t_end": 20})
    job = server.wait_finished(job_id)
    assert job["status"] == "completed" and job["spec"]["tableau"] == kutta3
    assert job["summary"]["tableau"].startswith("custom-")
    sol = raydamp.integrate(DampedPendulum(eps=0.01), [0.9 * math.pi], [0.0], method="rk", tableau=kutta3, h=0.2,
                            t_end=20)
    final = server.client.get(f"/v1/jobs/{job_id}/trajectory", params={"start": sol.t.size - 1}).json()
    assert final["q"][0][0] == sol.q[-1, 0] and final["p"][0][0] == sol.p[-1, 0]
    server.client.delete(f"/v1/jobs/{job_id}")  # the module's last test expects no jobs


def test_a_key_named_twice_is_422_not_the_last_value(module_server):
    # {"h": 0.1, ..., "h": 10} ran at h = 10 (a service audit), where an unknown key is refused; a sweep too.
    body = '{"model": "damped_pendulum", "h": 0.1, "n_steps": 10, "h": 10, "initial_state": {"rest": true}}'
    for path, content in (("/v1/jobs", body), ("/v1/sweeps", '{"job": ' + body + ', "grid": {"eps": [0.1]}}')):
        response = module_server.client.post(path, content=content, headers={"Content-Type": "application/json"})
        assert response.status_code == 422, response.text
        assert response.json()["detail"][0]["ctx"]["error"] == "the key 'h' appears twice in one object"
