"""Every list of a job or a sweep is refused by its length before any of its items is read (issue 44, N2 and
item 2): 500,000 bad save_dofs were validated one by one (5-10 s, +1 GB, /healthz blocked) before the length.

The list fields are read from /openapi.json, so a list added later is covered: the test fails until one of
the example bodies below holds it. Each list in turn gets 200 kB of bad items (null, which no item type
takes), and the answer must be one error, the length's, at that list's path: had the items been read, their
errors would come first. The times of these answers and of /healthz meanwhile are
benchmarks/bench_list_bounds.py's."""

from __future__ import annotations

import copy
import json
from collections.abc import Iterator

import pytest

UPLOAD = "0123456789abcdef0123456789abcdef"
# 40,000 bad items: past every bound but a structure's or a series' (which no body can pass), and small enough
# for 35 requests in a few seconds; benchmarks/bench_list_bounds.py sends 2 MB (about 400,000)
_BODY_BYTES = 200_000

_JOB = {"method": "3s", "h": 0.1, "n_steps": 10, "initial_state": {"q": [0.1], "p": [0.0]}}
_TERMS = {"terms": [
    {"harmonic": {"amplitude": [1.0], "omega": 1.0}},
    {"series": {"t": [0.0, 1.0], "values": [0.0, 1.0], "direction": {"ground": [1.0]}}},
    {"series": {"t": [0.0, 1.0], "values": [[0.0], [1.0]]}},
    {"series": {"t": [0.0, 1.0], "values": [0.0, 1.0], "direction": [1.0]}},
    {"expression": {"expression": "a*t", "parameters": {"a": 1.0}, "direction": [1.0]}},
    {"file": {"id": UPLOAD, "direction": [1.0], "dt": 0.1}}]}
# Valid bodies that, together, hold every list field of the two request schemas.
EXAMPLES = [
    ("/v1/jobs", {**_JOB, "model": "elastic_pendulum", "parameters": {"L0": 1.0},
                  "initial_state": {"q": [0.1, 0.0], "p": [0.0, 0.0]}, "save_dofs": [0],
                  "method": "rks", "tableau": {"A": [[0.5]], "b": [1.0], "c": [0.5]},
                  "load": _TERMS, "ground_motion": {"acceleration": {"series": {"t": [0.0, 1.0], "values": [0.0, 1.0]}},
                                                    "direction": [1.0, 0.0]}}),
    ("/v1/jobs", {**_JOB, "model": "damped_pendulum", "parameters": {"eps": [0.1]},
                  "events": [{"g": "q[0]", "name": "vertical"}]}),
    ("/v1/jobs", {**_JOB, "system": {"coordinates": ["x", "y"], "potential": "x^2 + y^2", "mass": [1.0, 2.0],
                                     "damping": {"diagonal": [1.0, 1.0]}}}),
    ("/v1/jobs", {**_JOB, "system": {"coordinates": 2, "potential": "q0^2", "mass": [[1.0, 0.0], [0.0, 1.0]],
                                     "damping": {"matrix": [[1.0, 0.0], [0.0, 1.0]]}}}),
    ("/v1/jobs", {**_JOB, "system": {"coordinates": 1, "potential": "q0^2",
                                     "damping": {"dampers": [{"on": "q0"}]}}}),
    ("/v1/jobs", {**_JOB, "system": {"kind": "chain", "n": 4, "dampers": {"bonds": [1], "sites": [0],
                                                                          "c": [1.0, 1.0]}}}),
    ("/v1/jobs", {**_JOB, "initial_state": {"rest": True},
                  "system": {"kind": "linear_structure", "M": {"diagonal": [1.0, 1.0]},
                             "K": {"coo": {"shape": [2, 2], "rows": [0, 1], "cols": [0, 1], "values": [1.0, 1.0]}},
                             "f": [1.0, 0.0]}}),
    ("/v1/jobs", {**_JOB, "initial_state": {"rest": True},
                  "system": {"kind": "structure", "M": {"diagonal": [1.0, 1.0]}, "f": [1.0, 0.0],
                             "springs": [{"dofs": [0], "material": {"kind": "elastic_plastic", "k": 1.0, "fy": 1.0}},
                                         {"dofs": [0, 1], "material": {"kind": "elastic_plastic", "k": 1.0,
                                                                      "fy": 1.0}}]},
                  "envelope": ["drift", "displacement"], "collapse": [1.0, 1.0]}),
    ("/v1/jobs", {**_JOB, "initial_state": {"q": [1.0, 0.0], "p": [0.0, 0.0]},
                  "system": {"coordinates": ["x", "y"], "potential": "y", "constraints": ["x^2 + y^2 - 1"]}}),
    ("/v1/jobs", {**_JOB, "initial_state": {"q": [1.0, 0.0, 0.0, 2.0], "p": [0.0, 1e-3, -7e-4, 0.0]},
                  "system": {"kind": "planets", "masses": [1e-3, 1e-3], "eps": [0.0, 1e-3],
                             "drag": [[1.0, 0.0], [0.0, 0.0]]}}),
    ("/v1/jobs", {**_JOB, "initial_state": {"q": [1.0, 0.0, 0.0], "p": [0.0, 1.0, 0.1]},
                  "system": {"kind": "kepler", "dim": 3, "eps": 1e-3,
                             "drag": [[0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1.0]]}}),
    ("/v1/sweeps", {"job": {**_JOB, "model": "damped_pendulum", "work": False}, "grid": {"eps": [0.1, 0.2]}}),
]


def _resolve(schema: dict, defs: dict) -> tuple[dict, str | None]:
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[1]
        return defs[name], name.removesuffix("-Input")  # FastAPI's name of a request's form of a model
    return schema, None


def _variants(schema: dict) -> list[dict]:
    """The forms a value of the schema may take (anyOf and oneOf, at any depth)."""
    inner = schema.get("anyOf") or schema.get("oneOf")
    return [form for variant in inner for form in _variants(variant)] if inner else [schema]


def _values(schema: dict) -> dict | None:
    """The schema of a dict's values (additionalProperties, or its keys' pattern's), None for no dict."""
    if isinstance(schema.get("additionalProperties"), dict):
        return schema["additionalProperties"]
    return next(iter(schema.get("patternProperties", {}).values()), None)


def schema_lists(schema: dict, defs: dict, field: str, seen: frozenset = frozenset()) -> Iterator[str]:
    """The names of the list fields under a schema: "Model.field" with a [] per nested list and a {} for a
    dict's values."""
    for variant in _variants(schema):
        variant, name = _resolve(variant, defs)
        if name is not None:
            if name in seen:
                continue
            seen = seen | {name}
            for key, inner in variant.get("properties", {}).items():
                yield from schema_lists(inner, defs, f"{name}.{key}", seen)
        elif variant.get("type") == "array":
            yield field
            yield from schema_lists(variant.get("items", {}), defs, field + "[]", seen)
        elif variant.get("type") == "object" and _values(variant) is not None:
            yield from schema_lists(_values(variant), defs, field + "{}", seen)


def _fits(value, variant: dict, defs: dict) -> bool:
    """Whether a valid value is of this variant's form (its type; for an object, its keys)."""
    variant, name = _resolve(variant, defs)
    if isinstance(value, list):  # an array whose items are of the first item's form (a row of numbers, a matrix)
        return variant.get("type") == "array" and (not value or any(
            _fits(value[0], item, defs) for item in _variants(variant.get("items", {}))))
    if isinstance(value, dict):
        if name is None:
            return variant.get("type") == "object"
        return set(value) <= set(variant.get("properties", {})) and set(variant.get("required", [])) <= set(value)
    return variant.get("type") not in ("array", "object")


def instance_lists(value, schema: dict, defs: dict, field: str, path: tuple) -> Iterator[tuple[str, tuple, int]]:
    """(list field's name, JSON path, most items) of every list in a valid value of the schema."""
    if not isinstance(value, (list, dict)):
        return
    variant = next(v for v in _variants(schema) if _fits(value, v, defs))
    variant, name = _resolve(variant, defs)
    if isinstance(value, list):
        yield field, path, variant.get("maxItems")
        for i, item in enumerate(value):
            yield from instance_lists(item, variant.get("items", {}), defs, field + "[]", (*path, i))
    elif name is not None:
        for key, item in value.items():
            yield from instance_lists(item, variant["properties"][key], defs, f"{name}.{key}", (*path, key))
    else:
        for key, item in value.items():
            yield from instance_lists(item, _values(variant), defs, field + "{}", (*path, key))


def _replaced(body: dict, path: tuple, value) -> dict:
    out = copy.deepcopy(body)
    inner = out
    for part in path[:-1]:
        inner = inner[part]
    inner[path[-1]] = value
    return out


@pytest.fixture(scope="module")
def openapi(module_server) -> dict:
    return module_server.client.get("/openapi.json").json()


def _request_schema(openapi: dict, route: str) -> dict:
    return openapi["paths"][route]["post"]["requestBody"]["content"]["application/json"]["schema"]


def test_every_list_field_has_an_example(openapi):
    """A sweep's job is a job: its lists are the job's, each covered by one example of either route."""
    defs = openapi["components"]["schemas"]
    fields = {name for route in ("/v1/jobs", "/v1/sweeps")
              for name in schema_lists(_request_schema(openapi, route), defs, "body")}
    assert {"JobSpec.save_dofs", "TableauInput.A[]", "SeriesBody.t", "ChainDampers.bonds", "SweepSpec.grid{}",
            "TermsLoad.terms"} <= fields
    found = {name for route, body in EXAMPLES
             for name, _, _ in instance_lists(body, _request_schema(openapi, route), defs, "body", ())}
    assert fields <= found, f"list fields without an example: {sorted(fields - found)}"


def test_every_list_is_refused_by_its_length_before_its_items(module_server, openapi):
    defs = openapi["components"]["schemas"]
    done: set[str] = set()
    for route, body in EXAMPLES:
        for name, path, most in instance_lists(body, _request_schema(openapi, route), defs, "body", ()):
            if name in done:
                continue
            done.add(name)
            assert most is not None, f"{name}: a list without maxItems"
            size = len(json.dumps(body, separators=(",", ":")))
            bad = [None] * ((_BODY_BYTES - size) // 5)
            data = json.dumps(_replaced(body, path, bad), separators=(",", ":"))
            response = module_server.client.post(route, content=data, headers={"content-type": "application/json"})
            assert response.status_code == 422, (name, response.text[:500])
            detail = response.json()["detail"]
            if most < len(bad):  # the length's error alone: had the items been read, theirs would be there too
                assert [(error["type"], error["loc"]) for error in detail] == [("too_long", ["body", *path])], \
                    (name, detail[:3])
                assert f"at most {most} items" in detail[0]["msg"] and f"not {len(bad)}" in detail[0]["msg"]
            else:  # a list that may be this long (a structure's): one error naming its first bad items
                assert [error["loc"] for error in detail] == [["body", *path]], (name, detail[:3])
                assert detail[0]["msg"].startswith("items 0, 1, 2, "), (name, detail[0]["msg"])
                assert detail[0]["msg"].endswith("and more are not finite numbers") or \
                    detail[0]["msg"].endswith("and more are not integers >= 0"), (name, detail[0]["msg"])
    assert len(done) >= 30
