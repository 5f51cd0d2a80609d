"""A built-in model's parameters are written once, in its C++ struct's table (exported as
_core.models()): the Python signature, defaults, docs and checks, describe_models(), the service's
GET /v1/models, make_model, and the ensemble's per-member parameters all equal that table. A
parameter added to the table appears everywhere; one added anywhere else alone fails here."""

from __future__ import annotations

import inspect
import re

import numpy as np
import pytest

import raydamp
from raydamp import _core
from raydamp.models import MODELS, describe_models, make_model
from raydamp.run.ensemble import member_parameters
from raydamp.systems.models import BuiltinModel

CATALOGUE = {entry["name"]: entry for entry in _core.models()}
MODEL_NAMES = sorted(CATALOGUE)
# A configuration of each model away from its singular points, and a momentum.
STATES = {"damped_pendulum": ([2.0], [0.1]),
          "elastic_pendulum": ([0.0, 1.55884573, -0.6], [1.34164079, 0.0, 0.0])}


def default(row):
    return row["default"] if row["size"] == 1 else tuple(row["default"])


def test_every_built_in_model_is_in_the_catalogue_and_back():
    assert set(MODELS) == set(CATALOGUE) == set(STATES)
    assert [m["name"] for m in describe_models()] == [e["name"] for e in _core.models()]


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_signature_defaults_and_docs_are_the_tables(name):
    entry, cls = CATALOGUE[name], MODELS[name]
    rows = entry["parameters"]
    signature = inspect.signature(cls)
    assert list(signature.parameters) == [r["name"] for r in rows]
    assert [p.default for p in signature.parameters.values()] == [default(r) for r in rows]
    # help() shows __init__'s signature too
    assert list(inspect.signature(cls.__init__).parameters)[1:] == [r["name"] for r in rows]
    assert cls.parameter_docs == {r["name"]: r["description"] for r in rows}
    assert cls.momentum_names == tuple(entry["momenta"])
    model = cls()
    assert model.parameters == {r["name"]: default(r) for r in rows}
    assert model.dim == entry["dim"]
    assert list(model._core_model.values) == [x for r in rows for x in np.atleast_1d(r["default"])]
    assert model.describe() == {"model": name, "parameters": {r["name"]: r["default"] for r in rows}}


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_describe_models_and_make_model_are_the_tables(name):
    entry = CATALOGUE[name]
    described = {m["name"]: m for m in describe_models()}[name]
    assert described["dim"] == entry["dim"] and described["momenta"] == entry["momenta"]
    assert described["parameters"] == [{"name": r["name"], "default": r["default"], "description": r["description"]}
                                       for r in entry["parameters"]]
    # every name the table has is one make_model takes, and no other
    given = {r["name"]: default(r) for r in entry["parameters"]}
    assert make_model(name, given).parameters == given
    with pytest.raises(ValueError, match=f"parameters.extra: {name} has no parameter 'extra'"):
        make_model(name, {**given, "extra": 1.0})


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_checks_are_the_tables_rules(name):
    cls = MODELS[name]
    for row in CATALOGUE[name]["parameters"]:
        bad = {">= 0": -1.0, "> 0": 0.0, "finite": float("nan")}[row["rule"]]
        value = bad if row["size"] == 1 else [bad] * row["size"]
        message = f"{row['name']} must be {row['rule']}" if row["size"] == 1 else f"{row['name']}"
        with pytest.raises(ValueError, match=re.escape(message)):
            cls(**{row["name"]: value})
        # and the core refuses the same value, naming it alike
        values = [x for r in CATALOGUE[name]["parameters"] for x in np.atleast_1d(r["default"])]
        at = [r["name"] for r in CATALOGUE[name]["parameters"]].index(row["name"])
        flat = sum((r["size"] for r in CATALOGUE[name]["parameters"][:at]), 0)
        values[flat] = bad
        core_name = row["name"] if row["size"] == 1 else f"{row['name']}[0]"
        with pytest.raises(ValueError, match=re.escape(f"{core_name} must be")):
            getattr(_core, CATALOGUE[name]["class_name"])(values)


@pytest.mark.parametrize("name", MODEL_NAMES)
def test_every_parameter_varies_per_member_and_members_equal_single_runs(name):
    entry, cls = CATALOGUE[name], MODELS[name]
    rows = entry["parameters"]
    assert member_parameters(cls()) == tuple(r["name"] for r in rows)
    assert cls().member_parameters() == {r["name"]: r["size"] for r in rows}
    members = 5
    rng = np.random.default_rng(3)
    # every parameter per member, each near its default (vectors (members, size))
    per_member = {r["name"]: np.asarray(r["default"]) * rng.uniform(0.8, 1.2, (members, r["size"])).squeeze(-1)
                  if r["size"] == 1 else np.asarray(r["default"]) + rng.normal(0.0, 0.1, (members, r["size"]))
                  for r in rows}
    q0, p0 = STATES[name]
    ens = raydamp.integrate_ensemble(cls(), np.tile(q0, (members, 1)), p0, parameters=per_member, method="3s",
                                     h=0.05, n_steps=40, save_every=8)
    assert ens.success
    for i in range(members):
        model = cls(**{k: v[i] for k, v in per_member.items()})
        ref = raydamp.integrate(model, q0, p0, method="3s", h=0.05, n_steps=40, save_every=8)
        member = ens.member(i)
        for key in ("t", "q", "p", "energy", "momentum"):
            assert np.array_equal(getattr(member, key), getattr(ref, key)), (i, key)
    # the core's per-member names are the table's value names, resolved by the core; others are refused
    core = cls()._core_model
    assert entry["value_names"] == [r["name"] if r["size"] == 1 else f"{r['name']}[{j}]"
                                    for r in rows for j in range(r["size"])]
    values = np.array([[x for r in rows for x in np.atleast_1d(r["default"])]])
    out = type(core).integrate_ensemble([core], np.zeros(1, dtype=np.int64), entry["value_names"], values, "3s", "", "",
                                        np.array([q0], float), np.array([p0], float), 0.05, 2, 0.05, 1, 1, None, None)
    assert list(out["status"]) == ["completed"]
    with pytest.raises(ValueError, match=f"parameters: {name} has no parameter 'extra'"):
        type(core).integrate_ensemble([core], np.zeros(1, dtype=np.int64), ["extra"], np.zeros((1, 1)), "3s", "", "",
                                      np.array([q0], float), np.array([p0], float), 0.05, 2, 0.05, 1, 1, None, None)


def test_a_row_added_to_the_table_appears_everywhere_in_python(monkeypatch):
    # What adding a parameter to a C++ table does on the Python side, shown without a rebuild: a
    # catalogue entry with one more row makes a class whose signature, defaults, docs, checks,
    # parameters, JSON form and per-member parameters all carry it, with no Python edited.
    import raydamp.systems.models as models

    entry = dict(CATALOGUE["damped_pendulum"])
    entry["parameters"] = [*entry["parameters"],
                           {"name": "c", "size": 1, "default": 0.5, "rule": "> 0", "description": "a new coefficient"}]
    built = []

    class Core:
        def __init__(self, values):
            built.append(list(values))
            self.dim = 1

    monkeypatch.setitem(models._CATALOGUE, "extended", {**entry, "name": "extended", "class_name": "Extended"})
    monkeypatch.setattr(_core, "Extended", Core, raising=False)

    class Extended(BuiltinModel):
        """A damped pendulum with one more parameter."""

        name = "extended"

    assert str(inspect.signature(Extended)) == "(eps: float = 0.01, c: float = 0.5)"
    assert Extended.parameter_docs["c"] == "a new coefficient"
    model = Extended(c=2.0)
    assert model.parameters == {"eps": 0.01, "c": 2.0} and built[-1] == [0.01, 2.0]
    assert model.describe() == {"model": "extended", "parameters": {"eps": 0.01, "c": 2.0}}
    assert model.member_parameters() == {"eps": 1, "c": 1}
    assert model.replace(eps=0.2).parameters == {"eps": 0.2, "c": 2.0}
    with pytest.raises(ValueError, match="c must be > 0, got 0.0"):
        Extended(c=0.0)
