"""The typed load (raydamp.loads.forms, re-exported by raydamp.jobs): one schema for Load.from_dict, a job's
"load" and "ground_motion", and /openapi.json; and the job's answers about its files (uploads, local_paths,
compiles) that a service asks instead of walking the JSON."""

from __future__ import annotations

import io

import numpy as np
import pytest
from pydantic import ValidationError

import raydamp
from raydamp.jobs import JobSpec, LoadInput, client_path, parse_job
from raydamp.loads.forms import MAX_SERIES
from raydamp.models import DampedPendulum

UPLOAD = "0123456789abcdef0123456789abcdef"
OTHER = "fedcba9876543210fedcba9876543210"
JOB = {"model": "damped_pendulum", "method": "3s", "h": 0.1, "n_steps": 10,
       "initial_state": {"q": [0.1], "p": [0.0]}}


def _refs(schema: dict) -> set[str]:
    return {variant["$ref"].rsplit("/", 1)[1] for variant in schema.get("anyOf", schema.get("oneOf", []))
            if "$ref" in variant}


def test_the_job_schema_describes_every_load_form_and_the_ground_motion():
    schema = JobSpec.model_json_schema()
    defs = schema["$defs"]
    load = next(v for v in schema["properties"]["load"]["anyOf"] if v.get("type") != "null")
    assert _refs(load) == {"HarmonicLoad", "SeriesLoad", "ExpressionLoad", "FileLoad", "TermsLoad"}
    assert set(defs["HarmonicBody"]["required"]) == {"amplitude", "omega"}
    assert set(defs["FileBody"]["properties"]) == {"id", "path", "direction", "factor", "dt", "hold"}
    assert defs["SeriesBody"]["properties"]["t"]["maxItems"] == MAX_SERIES
    ground = next(v for v in schema["properties"]["ground_motion"]["anyOf"] if v.get("type") != "null")
    assert ground["$ref"].endswith("/GroundMotionInput")
    assert _refs(defs["GroundMotionInput"]["properties"]["acceleration"]) == _refs(load)
    # step_size: still taken for h, and marked deprecated where a client's tools look
    assert schema["properties"]["step_size"]["deprecated"] is True
    assert raydamp.jobs.JobSummary.model_json_schema()["properties"]["step_size"]["deprecated"] is True
    assert parse_job({**{k: v for k, v in JOB.items() if k != "h"}, "step_size": 0.2}).h == 0.2


def test_from_dict_reads_the_typed_form_and_names_the_path():
    model = DampedPendulum()
    load = raydamp.Load.from_dict({"terms": [{"harmonic": {"amplitude": 2.0, "omega": 3.0}},
                                             {"expression": {"expression": "a*t", "parameters": {"a": 0.5},
                                                             "direction": [1.0]}}], "amplitude": 2})
    t = np.array([0.3, 0.7])
    np.testing.assert_allclose(load.values(model, t)[:, 0], 2 * (2 * np.sin(3 * t) + 0.5 * t), rtol=1e-14)
    cases = [
        ({"terms": [{"series": {"t": [0, 1], "values": [0, 1]}}, {"harmonic": {"amplitude": [1], "omega": "x"}}]},
         r"^load\.terms\[1\]\.harmonic\.omega must be a real number, got 'x'"),
        ({"harmonic": {"amplitude": [1, "a"], "omega": 1}}, r"^load\.harmonic\.amplitude\[1\] must be a real number"),
        ({"harmnic": {"amplitude": [1], "omega": 1}}, r"^load: a load is \{\"harmonic\""),
        ([1, 2], r"^load: a load is"),
        ({"file": {"direction": [1.0]}}, r"^load\.file: give exactly one of path and id"),
        ({"series": {"t": [0, 1], "values": [0, 1], "direction": {"ground": [1], "x": 2}}},
         r"^load\.series\.direction\.x: unknown key"),
        ({"terms": [{"series": {"t": [0, 1]}}]}, r"^load\.terms\[0\]\.series\.values: missing"),
    ]
    for plain, message in cases:
        with pytest.raises(ValueError, match=message):
            raydamp.Load.from_dict(plain)
    with pytest.raises(ValueError, match=r"^ground_motion\.acceleration\.series\.t\[1\] must be finite"):
        raydamp.GroundMotion.from_dict({"acceleration": {"series": {"t": [0, float("inf")], "values": [0, 1]}},
                                        "direction": [1.0]})
    # found by the fuzz test: a harmonic whose amplitude is itself {"ground": r} was a TypeError (a 500)
    with pytest.raises(ValueError, match=r"^ground_motion\.acceleration: a harmonic ground acceleration has a scalar"):
        raydamp.GroundMotion.from_dict({"acceleration": {"harmonic": {"amplitude": {"ground": [1.0]}, "omega": 1.0}},
                                        "direction": [1.0]})


def test_a_jobs_load_is_checked_when_parsed_at_the_path_the_client_wrote():
    with pytest.raises(ValidationError) as caught:
        JobSpec.model_validate({**JOB, "load": {"terms": [{"harmonic": {"amplitude": [1.0], "omega": 1.0}},
                                                          {"series": {"t": [0.0, 1.0], "values": [0.0, "x"]}}]}})
    assert [client_path(e["loc"]) for e in caught.value.errors()] == [("load", "terms", 1, "series", "values", 1)]
    # A stored job keeps its load as written (no defaults added), and it parses again to the same load
    spec = JobSpec.model_validate({**JOB, "load": {"harmonic": {"amplitude": [0.1], "omega": 0.8}}})
    assert spec.model_dump(mode="json")["load"] == {"harmonic": {"amplitude": [0.1], "omega": 0.8}}
    assert JobSpec.model_validate(spec.model_dump(mode="json")).load == spec.load


def test_a_job_says_which_files_it_reads_and_whether_it_compiles():
    structure = {"kind": "linear_structure", "M": {"file": UPLOAD}, "K": {"file": "/data/K.mtx"}}
    spec = JobSpec.model_validate({
        "system": structure, "method": "3s", "h": 0.1, "n_steps": 10,
        "initial_state": {"q": {"file": OTHER}, "p": {"file": UPLOAD}},
        "load": {"terms": [{"harmonic": {"amplitude": [1.0], "omega": 1.0}},
                           {"file": {"path": "/data/a.AT2", "direction": [1.0]}},
                           {"file": {"id": OTHER, "direction": [1.0], "dt": 0.1}}]},
        "ground_motion": {"acceleration": {"file": {"id": UPLOAD}}, "direction": [1.0]}})
    assert spec.uploads() == (OTHER, UPLOAD)
    assert spec.local_paths() == (("system", "K", "file"), ("load", "terms", 1, "file", "path"))
    assert not spec.compiles() and spec.compiled_form() is None
    expression = JobSpec.model_validate({**JOB, "ground_motion": {
        "acceleration": {"terms": [{"expression": {"expression": "sin(t)"}}]}, "direction": [1.0]}})
    assert expression.compiles() and expression.uploads() == () and expression.local_paths() == ()
    chain = JobSpec.model_validate({**JOB, "model": None, "system": {"kind": "chain", "n": 4, "bond": "expression",
                                                                      "parameters": {"potential": "r^2/2"}},
                                    "initial_state": {"rest": True}})
    assert chain.compiles() and not JobSpec.model_validate(JOB).compiles()
    system = JobSpec.model_validate({**JOB, "model": None, "system": {"coordinates": 1, "potential": "q0^2/2"}})
    key, data = system.compiled_form()
    assert system.compiles() and isinstance(key, str) and len(data) > 0


def test_a_load_type_adapter_is_the_schema_of_load_from_dict():
    from pydantic import TypeAdapter

    plain = (raydamp.Load.harmonic([0.2], 1.5) + raydamp.Load.series([0.0, 1.0], [[0.0], [1.0]])).to_dict()
    assert TypeAdapter(LoadInput).validate_python(plain).model_dump(exclude_unset=True) == plain


# ---- uploads cut short: every truncated header is a ValueError naming the file ----

def _npy_bytes() -> bytes:
    out = io.BytesIO()
    np.save(out, np.column_stack([np.arange(4) * 0.1, np.ones(4)]))
    return out.getvalue()


AT2 = (b"PEER NGA STRONG MOTION DATABASE RECORD\nTEST EVENT, 1 JAN 2000\nACCELERATION TIME SERIES IN UNITS OF G\n"
       b"NPTS=    4, DT=   .0100 SEC\n  .1000000E-01  .2000000E-01 -.3000000E-01  .4000000D-01\n")
MTX = (b"%%MatrixMarket matrix coordinate real symmetric\n% a comment\n2 2 3\n1 1 2.0\n2 1 -1.0\n2 2 2.0\n")


@pytest.mark.parametrize(("name", "content", "header"), [("r.npy", _npy_bytes(), 128),
                                                          ("r.AT2", AT2, AT2.index(b"SEC\n") + 4),
                                                          ("K.mtx", MTX, MTX.index(b"2 2 3\n") + 6)])
def test_a_file_cut_at_any_byte_of_its_header_is_refused_naming_it(name, content, header):
    """Issue 44, N4: a .npy header cut inside its parenthesis let tokenize.TokenError out of the reader (a 500)."""
    from raydamp.loads.records import parse_record
    from raydamp.systems.structure import read_matrix

    for cut in range(header):
        data = content[:cut]
        try:
            if name.endswith(".mtx"):
                read_matrix(io.BytesIO(data), name)
            else:
                parse_record(data, name=name)
        except ValueError as error:
            assert name in str(error), (cut, str(error))
        else:
            raise AssertionError(f"{name} cut after {cut} bytes was read")
