"""integrate_ensemble with a load per member: records of different lengths, each scaled (an incremental
dynamic analysis), each member equal to its single run and carrying its own load in its provenance."""

import numpy as np
import pytest

import raydamp
from raydamp.jobs.build import job_arguments

FRAME = raydamp.LinearStructure(np.eye(2), np.array([[200.0, -100.0], [-100.0, 100.0]]), alpha=0.3)
RUN = {"method": "3s", "h": 0.005, "t_end": 6.0}


def records():
    rng = np.random.default_rng(5)
    # 3, 4.5 and 7 s long: the shorter ones end before the run does, which then goes on in free vibration
    return [raydamp.GroundMotion((np.arange(n) * 0.01, rng.standard_normal(n)), [1.0, 1.0]) for n in (301, 451, 701)]


def test_each_member_runs_its_own_scaled_record_as_its_single_run():
    motions, scales = records(), [0.5, 2.0]
    listed = [motion for motion in motions for _ in scales]
    amplitudes = scales * len(motions)
    ensemble = raydamp.integrate_ensemble(FRAME, np.zeros(2), np.zeros(2), load=listed,
                                          parameters={"load.amplitude": amplitudes}, threads=2, **RUN)
    prescaled = raydamp.integrate_ensemble(FRAME, np.zeros(2), np.zeros(2), threads=1, **RUN,
                                           load=[m * a for m, a in zip(listed, amplitudes)])
    assert ensemble.success and ensemble.members == 6
    peaks = []
    for i, (motion, amplitude) in enumerate(zip(listed, amplitudes)):
        single = raydamp.integrate(FRAME, [0.0, 0.0], [0.0, 0.0], load=motion * amplitude, **RUN)
        np.testing.assert_array_equal(ensemble.member(i).q, single.q)
        np.testing.assert_array_equal(prescaled.member(i).q, single.q)
        peaks.append(np.max(np.abs(single.q)))
    # the members differ (a shared or misindexed load would give equal peaks), and scale linearly
    np.testing.assert_allclose(peaks[1::2], 4.0 * np.array(peaks[0::2]), rtol=1e-12)
    assert len(set(np.round(peaks[0::2], 12))) == 3


def test_a_members_provenance_holds_its_own_load_and_runs_again():
    motions = records()
    ensemble = raydamp.integrate_ensemble(FRAME, np.zeros(2), np.zeros(2), load=[motions[2], motions[0], motions[2]],
                                          parameters={"load.amplitude": [1.0, 3.0, 0.25]}, **RUN)
    spec = ensemble.provenance
    assert spec["ensemble"]["load_of_member"] == [0, 1, 0] and len(spec["ensemble"]["loads"]) == 2
    for i in range(3):
        member = ensemble.member(i)
        model, q0, p0, options = job_arguments(member.provenance)
        again = raydamp.integrate(model, q0, p0, **options)
        np.testing.assert_array_equal(again.q, member.q)


@pytest.mark.parametrize(("arguments", "named"), [
    (dict(load=[]), r"load: an empty list"),
    (dict(load=[raydamp.Load()] * 2, q0=np.zeros((3, 2))), r"load: 2 loads for 3 members; give one load per member"),
    (dict(load=[raydamp.Load(), "record.AT2"]), r"load\[1\] must be a raydamp.Load or raydamp.GroundMotion"),
    (dict(load=[raydamp.Load.harmonic([1.0, 0.0], 2.0)] * 2, parameters={"load.omega": [1.0, 2.0]}),
     r"parameters.load.omega: with a load per member only load.amplitude varies per member"),
])
def test_bad_per_member_loads_are_refused_naming_the_argument(arguments, named):
    arguments = {"q0": np.zeros(2), "p0": np.zeros(2), **arguments}
    with pytest.raises(ValueError, match=named):
        raydamp.integrate_ensemble(FRAME, method="3s", h=0.01, n_steps=5, **arguments)
