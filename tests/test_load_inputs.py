"""Loads as data: their shapes, files and sums give the forces they say, and bad input gets a
ValueError naming the argument."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum, ElasticPendulum


def line_structure(n: int = 3) -> raydamp.LinearStructure:
    K = 2 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    return raydamp.LinearStructure(np.diag(np.arange(1.0, n + 1)), K, alpha=0.1)


AT2 = """PEER NGA STRONG MOTION DATABASE RECORD
TEST EVENT, 1 JAN 2000, STATION, 0
ACCELERATION TIME SERIES IN UNITS OF G
NPTS=    7, DT=   .0100 SEC
  .1000000E-01  .2000000E-01 -.3000000E-01  .4000000E-01
  .0000000E+00 -.1000000E-01  .5000000E-02
"""


def test_series_is_piecewise_linear_zero_outside_and_held_on_request():
    model = line_structure()
    d = np.array([1.0, 0.0, -2.0])
    load = raydamp.Load.series([0.0, 1.0, 3.0], [0.0, 2.0, -2.0], d)
    f = load.values(model, [-1.0, 0.0, 0.5, 1.0, 2.0, 3.0, 3.5])
    expected = np.array([0.0, 0.0, 1.0, 2.0, 0.0, -2.0, 0.0])[:, None] * d
    np.testing.assert_allclose(f, expected, atol=1e-15)
    held = raydamp.Load.series([0.0, 1.0, 3.0], [0.5, 2.0, -2.0], d, hold=True).values(model, [-1.0, 4.0])
    np.testing.assert_allclose(held, np.array([[0.5], [-2.0]]) * d)


def test_uniform_and_irregular_times_interpolate_alike():
    model = line_structure()
    rng = np.random.default_rng(0)
    t = np.arange(200) * 0.01
    a = rng.standard_normal(200)
    uniform = raydamp.Load.series(t, a, [1.0, 1.0, 1.0])
    irregular = raydamp.Load.series(np.append(t, 2.5), np.append(a, 0.0), [1.0, 1.0, 1.0])
    probe = rng.uniform(0.0, 1.99, 500)
    np.testing.assert_allclose(uniform.values(model, probe), irregular.values(model, probe), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(uniform.values(model, probe)[:, 0], np.interp(probe, t, a), rtol=1e-12, atol=1e-14)


def test_vector_series_harmonic_expression_and_sum():
    model = line_structure()
    t = [0.0, 2.0]
    rows = [[1.0, 2.0, 3.0], [3.0, 2.0, 1.0]]
    vec = raydamp.Load.series(t, rows)
    np.testing.assert_allclose(vec.values(model, [1.0])[0], [2.0, 2.0, 2.0])
    harmonic = raydamp.Load.harmonic([0.0, 1.5, 0.0], 2.0, phase=0.3)
    np.testing.assert_allclose(harmonic.values(model, [0.7])[0], [0.0, 1.5 * np.sin(1.4 + 0.3), 0.0])
    expr = raydamp.Load.expression("F0*sin(w*t)*exp(-t/tau)", {"F0": 2.0, "w": 3.0, "tau": 0.5}, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(expr.values(model, [0.4])[0, 2], 2.0 * np.sin(1.2) * np.exp(-0.8), rtol=1e-14)
    total = vec + harmonic + 2.0 * expr
    np.testing.assert_allclose(total.values(model, [0.4])[0],
                               vec.values(model, [0.4])[0] + harmonic.values(model, [0.4])[0]
                               + 2.0 * expr.values(model, [0.4])[0], rtol=1e-14)
    assert sum([vec, harmonic]).values(model, [0.4]).shape == (1, 3)


def test_parameters_and_with_parameters():
    load = raydamp.Load.harmonic([1.0], 2.0) + raydamp.Load.expression("a*t", {"a": 1.0}, [1.0])
    assert load.parameters == {"amplitude": 1.0, "omega": 2.0, "phase": 0.0, "a": 1.0}
    changed = load.with_parameters(omega=3.0, a=2.0, amplitude=0.5)
    model = DampedPendulum()
    np.testing.assert_allclose(changed.values(model, [0.5])[0, 0], 0.5 * (np.sin(1.5) + 2.0 * 0.5), rtol=1e-14)
    with pytest.raises(ValueError, match=r"load\.k: this load has no parameter 'k'"):
        load.with_parameters(k=1.0)


def test_files_at2_csv_npy(tmp_path):
    model = DampedPendulum()
    at2 = tmp_path / "rec.AT2"
    at2.write_text(AT2)
    load = raydamp.Load.from_file(at2, [1.0], factor=9.81)
    values = [0.01, 0.02, -0.03, 0.04, 0.0, -0.01, 0.005]
    np.testing.assert_allclose(load.values(model, np.arange(7) * 0.01)[:, 0], 9.81 * np.array(values), rtol=1e-12)
    csv = tmp_path / "rec.csv"
    csv.write_text("time,acc\n0,1\n0.5,3\n1.0,-1\n")
    np.testing.assert_allclose(raydamp.Load.from_file(csv, [2.0]).values(model, [0.25, 0.75])[:, 0], [4.0, 2.0])
    npy = tmp_path / "rec.npy"
    np.save(npy, np.array([1.0, 2.0, 4.0]))
    np.testing.assert_allclose(raydamp.Load.from_file(npy, [1.0], dt=0.1).values(model, [0.15])[:, 0], [3.0])
    old = tmp_path / "old.at2"
    old.write_text("a\nb\nc\n    3    0.02    NPTS, DT\n1 2 3\n")
    np.testing.assert_allclose(raydamp.Load.from_file(old, [1.0]).values(model, [0.03])[:, 0], [2.5])
    # A Fortran double's exponent: DT stopped at the D and was read as 1.0, every time 100 times too late.
    fortran = tmp_path / "fortran.AT2"
    fortran.write_text(AT2.replace("DT=   .0100", "DT=   1.0D-02").replace("-.3000000E-01", "-.3000000D-01"))
    np.testing.assert_allclose(raydamp.Load.from_file(fortran, [1.0]).values(model, np.arange(7) * 0.01)[:, 0],
                               values, rtol=1e-12)


@pytest.mark.parametrize("text,match", [
    (AT2.replace("NPTS=    7", "NPTS=    8"), r"NPTS=8 but the record has 7 values"),
    (AT2.replace("-.3000000E-01", "x.3"), r"line 5: 'x\.3' is not a number"),
    (AT2.replace("DT=   .0100", "DT=   -.0100"), r"DT must be > 0"),
    (AT2.replace("NPTS=    7, DT=   .0100 SEC", "seven points"), r"line 4 must give NPTS and DT"),
    (AT2.replace("DT=   .0100", "DT=   1.0DD2"), r"DT on line 4 is not a number: '1\.0DD2'"),
])
def test_malformed_at2_is_refused_naming_the_problem(tmp_path, text, match):
    path = tmp_path / "bad.AT2"
    path.write_text(text)
    with pytest.raises(ValueError, match=match):
        raydamp.Load.from_file(path, [1.0])


def test_bad_input_names_the_argument():
    model = ElasticPendulum()
    q0, p0 = [0.3, 0.1, -1.1], [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match=r"t: times must increase, but t\[2\] = 1\.0 <= t\[1\] = 1\.0"):
        raydamp.Load.series([0.0, 1.0, 1.0], [0.0, 1.0, 2.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"values\[1\] is not finite"):
        raydamp.Load.series([0.0, 1.0], [0.0, np.nan], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"values: 3 values for 2 times"):
        raydamp.Load.series([0.0, 1.0], [0.0, 1.0, 2.0], [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"load\.direction: length 2, the model has 3 coordinates"):
        raydamp.integrate(model, q0, p0, h=0.01, n_steps=2, load=raydamp.Load.series([0, 1], [0, 1], [1.0, 0.0]))
    with pytest.raises(ValueError, match=r"load\.amplitude: length 1, the model has 3 coordinates"):
        raydamp.integrate(model, q0, p0, h=0.01, n_steps=2, load=raydamp.Load.harmonic([1.0], 1.0))
    with pytest.raises(ValueError, match=r"load\.direction: needed"):
        raydamp.integrate(model, q0, p0, h=0.01, n_steps=2, load=raydamp.Load.series([0, 1], [0, 1]))
    with pytest.raises(ValueError, match=r"expression: unknown name 'x'"):
        raydamp.Load.expression("x*t", {}, [1.0, 0.0, 0.0])
    with pytest.raises(ValueError, match=r"dt must be > 0"):
        raydamp.Load.series(*raydamp.loads.records.from_array(np.ones(3), dt=0.0, source="x"), [1.0])
    with pytest.raises(ValueError, match=r"load must be a raydamp\.Load"):
        raydamp.integrate(model, q0, p0, h=0.01, n_steps=2, load=[1.0, 2.0])
    with pytest.raises(ValueError, match=r"method: 'midpoint' is an implicit step"):
        raydamp.integrate(model, q0, p0, method="midpoint", h=0.01, n_steps=2,
                          load=raydamp.Load.harmonic([1.0, 0.0, 0.0], 1.0))


def test_ground_motion_is_minus_m_r_ag():
    model = line_structure()
    t = [0.0, 1.0]
    motion = raydamp.GroundMotion((t, [0.0, 2.0]), [1.0, 1.0, 0.0])
    np.testing.assert_allclose(motion.values(model, [0.5])[0], -np.array([1.0, 2.0, 0.0]) * 1.0)
    np.testing.assert_allclose(motion.ground_part().values(model, [0.5])[0], [1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match=r"acceleration: a scalar history"):
        raydamp.GroundMotion(raydamp.Load.series(t, [0.0, 1.0], [1.0, 0.0, 0.0]), [1.0, 1.0, 1.0])


def test_provenance_carries_the_load():
    model = DampedPendulum()
    load = raydamp.Load.harmonic([0.2], 1.5) + raydamp.Load.series([0.0, 1.0], [0.0, 1.0], [1.0])
    sol = raydamp.integrate(model, [0.5], [0.0], h=0.01, t_end=1.0, load=load)
    assert sol.provenance["load"] == {"terms": [
        {"harmonic": {"amplitude": [0.2], "omega": 1.5, "phase": 0.0}},
        {"series": {"t": [0.0, 1.0], "values": [0.0, 1.0], "direction": [1.0]}}]}


def test_blowup_under_a_load_keeps_what_was_computed():
    model = DampedPendulum(eps=0.0)
    huge = raydamp.Load.harmonic([1e308], 0.1, phase=np.pi / 2)
    sol = raydamp.integrate(model, [0.1], [0.0], h=0.01, t_end=4.0, load=huge, method="sv")
    assert sol.status == "non_finite" and sol.t.size >= 2 and np.all(np.isfinite(sol.q))
    assert 100 < sol.failed_step < 400


def test_ensemble_members_vary_the_load_and_equal_their_single_runs():
    model = DampedPendulum(eps=0.1)
    load = raydamp.Load.harmonic([0.5], 1.0) + raydamp.Load.expression("a*t", {"a": 0.1}, [1.0])
    omegas, amplitudes, a = [0.5, 1.0, 1.5, 1.0], [1.0, 2.0, 0.5, 0.0], [0.1, 0.1, 0.3, 0.3]
    ens = raydamp.integrate_ensemble(model, [0.3], [0.0], h=0.01, t_end=3.0, load=load, save_every=10,
                                     parameters={"load.omega": omegas, "load.amplitude": amplitudes, "load.a": a},
                                     threads=2)
    assert ens.members == 4
    for i in range(4):
        single = raydamp.integrate(model, [0.3], [0.0], h=0.01, t_end=3.0, save_every=10,
                                   load=load.with_parameters(omega=omegas[i], amplitude=amplitudes[i], a=a[i]))
        np.testing.assert_array_equal(ens.member(i).q, single.q)
    free = raydamp.integrate(model, [0.3], [0.0], h=0.01, t_end=3.0, save_every=10)
    np.testing.assert_array_equal(ens.member(3).q, free.q)  # amplitude 0
    spec = ens.member(2).provenance
    assert spec["load"]["amplitude"] == 0.5
    assert spec["load"]["terms"][0]["harmonic"]["omega"] == 1.5
    assert spec["load"]["terms"][1]["expression"]["parameters"] == {"a": 0.3}
    with pytest.raises(ValueError, match=r"parameters\.load\.k: this load has no parameter 'k'"):
        raydamp.integrate_ensemble(model, [0.3], [0.0], h=0.01, n_steps=2, load=load, parameters={"load.k": [1, 2]})


def test_load_json_form_round_trips():
    model = DampedPendulum()
    load = (raydamp.Load.harmonic([0.2], 1.5, phase=0.1) + raydamp.Load.series([0.0, 1.0], [0.0, 1.0], [1.0])
            + 3.0 * raydamp.Load.expression("a*t", {"a": 2.0}, [1.0]))
    again = raydamp.Load.from_dict(load.to_dict())
    t = np.linspace(0.0, 2.0, 17)
    np.testing.assert_allclose(again.values(model, t), load.values(model, t), rtol=1e-15)
    motion = raydamp.GroundMotion(([0.0, 1.0], [0.0, 1.0]), [1.0])
    np.testing.assert_allclose(raydamp.Load.from_dict(motion.to_dict()).values(model, t), motion.values(model, t))
    with pytest.raises(ValueError, match=r"load\.terms\[0\]\.series\.t: times must increase"):
        raydamp.Load.from_dict({"terms": [{"series": {"t": [1, 0], "values": [0, 0], "direction": [1]}}]})
    with pytest.raises(ValueError, match=r"load\.harmonic\.omga: unknown key"):
        raydamp.Load.from_dict({"harmonic": {"amplitude": [1], "omga": 1}})


def test_uploaded_bytes_are_read_by_suffix_and_content():
    """parse_record (the service's upload check and resolver): the format from the suffix or the content,
    one column of values as (None, values), and a name that disagrees with the content refused."""
    from raydamp.loads.records import parse_record, record_format

    record, fmt = parse_record(AT2.encode(), name="rec.AT2")
    assert fmt == "at2" and record_format(AT2.encode()) == "at2"
    np.testing.assert_allclose(record.t, np.arange(7) * 0.01)
    record, fmt = parse_record(b"1\n2\n4\n", name="v.csv")
    assert fmt == "columns" and record.t is None and record.values.tolist() == [1.0, 2.0, 4.0]
    with pytest.raises(ValueError, match=r"v\.npy: not a NumPy array file"):
        parse_record(b"1\n2\n", name="v.npy")
    with pytest.raises(ValueError, match=r"x\.csv: t: times must increase"):
        parse_record(b"0,1\n1,2\n1,3\n", name="x.csv")
    with pytest.raises(ValueError, match=r"a Matrix Market matrix, not a record"):
        parse_record(b"%%MatrixMarket matrix coordinate real general\n1 1 1\n1 1 1\n", name="K.txt")
    with pytest.raises(ValueError, match=r"reads as npy; rename it"):
        parse_record(b"\x93NUMPY" + AT2.encode(), name="r.at2")


def test_a_resolved_record_of_values_takes_the_jobs_dt():
    files = {"v": (None, np.array([0.0, 1.0, 0.0])), "tv": (np.array([0.0, 1.0]), np.array([1.0, 3.0]))}
    load = raydamp.Load.from_dict({"file": {"id": "v", "direction": [2.0], "dt": 0.5}}, files=files.__getitem__)
    np.testing.assert_allclose(load.values(DampedPendulum(), [0.25, 0.5, 0.75])[:, 0], [1.0, 2.0, 1.0])
    with pytest.raises(ValueError, match=r"load\.file\.dt: file v holds one column of values"):
        raydamp.Load.from_dict({"file": {"id": "v", "direction": [1.0]}}, files=files.__getitem__)
    with pytest.raises(ValueError, match=r"load\.file\.dt: file tv has a time column"):
        raydamp.Load.from_dict({"file": {"id": "tv", "direction": [1.0], "dt": 0.1}}, files=files.__getitem__)
    with pytest.raises(ValueError, match=r"load\.file\.dt must be > 0"):
        raydamp.Load.from_dict({"file": {"id": "v", "direction": [1.0], "dt": 0.0}}, files=files.__getitem__)


@pytest.mark.parametrize("factor", ["x", None, True, [2.0]])
def test_a_ground_motions_factor_must_be_a_number(factor):
    """It was a TypeError (acceleration * factor), a traceback from raydamp run."""
    with pytest.raises(ValueError, match=r"^ground_motion\.factor must be a real number"):
        raydamp.GroundMotion.from_dict({"acceleration": {"series": {"t": [0, 1], "values": [1, 2]}},
                                        "direction": [1.0], "factor": factor})
