"""Views of stored jobs read what was stored: a job's spec is validated once, at submission, and kept as
JobSpec's normalised JSON (a view sends it as it is); a list reads its label and method from the stored
JSON in SQLite. Specs stored by an older service are brought to today's form when the store opens."""

from __future__ import annotations

import json
import sqlite3

from raydamp.jobs import JobSpec, SweepSpec
from raydamp_service.kinds.jobs import JobStore
from raydamp_service.kinds.sweeps import SweepStore
from raydamp_service.tasks.store import Database

PENDULUM = {"model": "damped_pendulum", "parameters": {"eps": 0.01}, "h": 0.1, "n_steps": 10,
            "initial_state": {"q": [1.0], "p": [0.0]}}
CHAIN = {"system": {"kind": "chain", "n": 4}, "method": "2s", "h": 0.1, "t_end": 1.0,
         "initial_state": {"mode": 1}}


def normalised(spec: dict) -> dict:
    return JobSpec.model_validate(spec).model_dump(mode="json")


def test_a_list_shows_the_label_and_method_the_spec_and_summary_give(store):
    def label(spec: dict) -> str:  # the rule a list applied to the parsed spec in Python before
        system = spec.get("system") or {}
        return spec.get("model") or system.get("name") or system.get("kind") or "system"

    spring = {**PENDULUM, "model": None, "parameters": {}, "system": {"coordinates": ["x"], "potential": "x^2/2"}}
    specs = [normalised(spec) for spec in (
        PENDULUM, CHAIN, {**spring, "system": {**spring["system"], "name": "spring"}},
        {**spring, "system": {**spring["system"], "name": ""}}, spring, {**PENDULUM, "method": "rks"})]
    ids = [store.create(spec).id for spec in specs]
    store.finish(ids[0], "completed", summary={"method": "2s"})  # the method run (chosen by raydamp) wins
    rows = {row["id"]: (row["label"], row["method"]) for row in store.listing(10)}
    assert [rows[i][0] for i in ids] == [label(spec) for spec in specs]
    assert [rows[i][0] for i in ids][:3] == ["damped_pendulum", "chain", "spring"]
    assert [rows[i][1] for i in ids] == ["2s", "2s", None, None, None, "rks"]
    assert [row["id"] for row in store.listing(10, "completed")] == [ids[0]]
    assert [row["id"] for row in store.listing(2)] == ids[:-3:-1]  # newest first


def test_specs_stored_by_an_older_service_are_normalised_once(tmp_path):
    path = tmp_path / "old.sqlite3"
    store = JobStore(path)
    store.open()
    # An older service's rows: the step size under its former name and no fields added since (work,
    # temperature, ...); and one that no longer validates, which stays as it was.
    old = {k: v for k, v in PENDULUM.items() if k != "h"} | {"step_size": 0.1}
    legacy, broken = store.create(old), store.create({"model": "damped_pendulum"})
    sweeps = SweepStore(store.db)
    sweeps.open()
    swept = sweeps.create({"job": old, "grid": {"parameters.eps": [0.1, 0.2]}}, members=2)
    store.close()
    with sqlite3.connect(path) as db:  # as if written before today's schema
        db.execute("DELETE FROM service WHERE key LIKE '%spec schema'")
    database = Database(path)
    reopened, sweeps = JobStore(database), SweepStore(database)
    reopened.open()
    sweeps.open()
    spec = reopened.get(legacy.id).spec
    assert spec == normalised(old) and spec["h"] == 0.1 and "step_size" not in spec and spec["work"] is True
    assert reopened.get(broken.id).spec == {"model": "damped_pendulum"}
    sweep = {"job": old, "grid": {"parameters.eps": [0.1, 0.2]}}
    assert sweeps.get(swept.id).spec == SweepSpec.model_validate(sweep).model_dump(mode="json")
    assert sweeps.get(swept.id).spec["job"]["h"] == 0.1
    # Normalised JSON is a fixed point: validating it again gives it back, so views need not.
    for job in (PENDULUM, CHAIN):
        assert normalised(json.loads(json.dumps(normalised(job)))) == normalised(job)
    database.close()
