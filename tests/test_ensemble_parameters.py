"""integrate_ensemble's ``parameters``: how they set the member count when q0 and p0 are single
states (scalars count as one member, a vector parameter's rows as its members), bools refused like
integrate's, and load parameters checked even on a load with no terms."""

from __future__ import annotations

import numpy as np
import pytest
from test_ensemble import same

import raydamp
from raydamp.models import DampedPendulum, ElasticPendulum

ELASTIC_Q0 = [0.0, 1.5, -0.6]


def oscillator() -> raydamp.LinearStructure:
    return raydamp.LinearStructure(np.eye(1), np.eye(1), alpha=0.1)


def test_a_scalar_load_parameter_with_single_states_is_one_member():
    # It once raised TypeError (len of a float) when no other argument gave the member count.
    load = raydamp.Load.harmonic([1.0], 1.0)
    ens = raydamp.integrate_ensemble(oscillator(), [0.0], [0.0], h=0.1, t_end=1, load=load,
                                     parameters={"load.omega": 2.0})
    assert ens.members == 1 and ens.parameters["load.omega"].tolist() == [2.0]
    single = raydamp.integrate(oscillator(), [0.0], [0.0], h=0.1, t_end=1, load=load.with_parameters(omega=2.0))
    assert same(ens.member(0), single)


def test_a_scalar_load_parameter_is_broadcast_to_the_members_a_list_gives():
    # The scalar first: the count once came from the first load parameter alone.
    load = raydamp.Load.harmonic([1.0], 1.0)
    amplitudes = [0.5, 1.0, 2.0]
    ens = raydamp.integrate_ensemble(oscillator(), [0.0], [0.0], h=0.1, t_end=1, load=load,
                                     parameters={"load.omega": 2.0, "load.amplitude": amplitudes})
    assert ens.members == 3 and ens.parameters["load.omega"].tolist() == [2.0] * 3
    for i, amplitude in enumerate(amplitudes):
        single = raydamp.integrate(oscillator(), [0.0], [0.0], h=0.1, t_end=1,
                                   load=load.with_parameters(omega=2.0, amplitude=amplitude))
        assert same(ens.member(i), single), i


@pytest.mark.parametrize("values", [[True], True, np.array([True, False]), [0.1, True], [np.True_]],
                         ids=["list", "scalar", "array", "mixed", "numpy-bool"])
def test_bool_parameters_are_refused(values):
    # np.asarray(..., float) once read True as eps = 1.0; integrate(eps=True) refuses it.
    members = np.size(values)
    with pytest.raises(ValueError, match=r"parameters\.eps must be an array of real numbers, got the bool True"):
        raydamp.integrate_ensemble(DampedPendulum(), [[0.5]] * members, [0.0], h=0.1, t_end=1,
                                   parameters={"eps": values})


def test_bool_vector_and_load_parameters_are_refused():
    with pytest.raises(ValueError, match=r"parameters\.g must be an array of real numbers, got the bool False"):
        raydamp.integrate_ensemble(ElasticPendulum(), ELASTIC_Q0, [0, 0, 0], h=0.1, t_end=1,
                                   parameters={"g": [[0, 0, -1], [0, 0, False]]})
    with pytest.raises(ValueError, match=r"parameters\.load\.amplitude must be 2 real numbers, got the bool True"):
        raydamp.integrate_ensemble(oscillator(), [[0.0]] * 2, [0.0], h=0.1, t_end=1,
                                   load=raydamp.Load.harmonic([1.0], 1.0), parameters={"load.amplitude": [True, 2]})


@pytest.mark.parametrize("values, shown", [(["0.1", "0.5"], "'0.1'"), (np.array(["0.1"]), "'0.1'"),
                                           ([b"0.1"], "b'0.1'"), ([0.1, None], "None"), ([1 + 2j], r"\(1\+2j\)")],
                         ids=["strings", "string-array", "bytes", "none", "complex"])
def test_parameters_that_are_not_real_numbers_are_refused(values, shown):
    # Strings were parsed as numbers ("0.1" ran as eps = 0.1) where integrate(eps="0.1") refuses them (API audit).
    with pytest.raises(ValueError, match=rf"^parameters\.eps must be an array of real numbers, got {shown}"):
        raydamp.integrate_ensemble(DampedPendulum(), [[0.5]] * len(values), [0.0], h=0.1, t_end=1,
                                   parameters={"eps": values})


def test_ragged_states_and_misshapen_vector_parameters_are_named():
    # NumPy's "inhomogeneous shape" and "could not be broadcast" messages named no argument (API audit).
    with pytest.raises(ValueError, match=r"^q0 must be an array of shape \(members, 1\) of real numbers, got rows"):
        raydamp.integrate_ensemble(DampedPendulum(), [[1.0], [1.0, 2.0]], [0.0], h=0.1, n_steps=2)
    with pytest.raises(ValueError, match=r"^parameters\.g must have shape \(1, 3\), got \(2,\)"):
        raydamp.integrate_ensemble(ElasticPendulum(), [ELASTIC_Q0], [0.0, 0, 0], h=0.1, n_steps=2,
                                   parameters={"g": [1.0, 2.0]})


def test_load_parameters_on_a_load_with_no_terms_are_checked():
    # They were once ignored, unknown names included, and ens.parameters came back empty.
    with pytest.raises(ValueError, match=r"parameters\.load\.bogus: this load has no parameter 'bogus' "
                                         r"\(it has: amplitude\)"):
        raydamp.integrate_ensemble(oscillator(), [[0.0]] * 2, [0.0], h=0.1, t_end=1, load=raydamp.Load(),
                                   parameters={"load.bogus": [1, 2]})
    with pytest.raises(ValueError, match=r"parameters\.load\.amplitude must be finite"):
        raydamp.integrate_ensemble(oscillator(), [[0.0]] * 2, [0.0], h=0.1, t_end=1, load=raydamp.Load(),
                                   parameters={"load.amplitude": [1, np.nan]})
    # A known name runs (an empty load scaled is still no force) and is recorded per member.
    ens = raydamp.integrate_ensemble(oscillator(), [1.0], [0.0], h=0.1, t_end=1, load=raydamp.Load(),
                                     parameters={"load.amplitude": [1.0, 3.0]})
    free = raydamp.integrate(oscillator(), [1.0], [0.0], h=0.1, t_end=1)
    assert ens.members == 2 and ens.parameters["load.amplitude"].tolist() == [1.0, 3.0]
    assert all(np.array_equal(ens.member(i).q, free.q) for i in range(2))


def test_per_member_vector_parameter_sets_the_member_count():
    # A single state of length n is used for every member: the 2 rows of g are 2 members. This once
    # raised "q0 must have shape (members, 3)" unless eps was also given per member.
    g = [[0.0, 0.0, -9.81], [0.0, 0.0, -1.0]]
    ens = raydamp.integrate_ensemble(ElasticPendulum(), ELASTIC_Q0, [0, 0, 0], parameters={"g": g}, h=0.1, t_end=1)
    assert ens.members == 2 and ens.parameters["g"].tolist() == g
    for i in range(2):
        single = raydamp.integrate(ElasticPendulum(g=g[i]), ELASTIC_Q0, [0, 0, 0], h=0.1, t_end=1)
        assert same(ens.member(i), single), i  # the same compiled step loop: bit for bit
    assert not np.array_equal(ens.q[0], ens.q[1])


def test_a_flat_vector_parameter_is_one_value_for_every_member():
    # g given as its 3 components is one g, not 3 members; the member count comes from eps.
    g = [0.0, 0.0, -2.0]
    one = raydamp.integrate_ensemble(ElasticPendulum(), ELASTIC_Q0, [0, 0, 0], parameters={"g": g}, h=0.1, t_end=1)
    assert one.members == 1
    assert same(one.member(0), raydamp.integrate(ElasticPendulum(g=g), ELASTIC_Q0, [0, 0, 0], h=0.1, t_end=1))
    eps = [0.0, 0.2]
    ens = raydamp.integrate_ensemble(ElasticPendulum(), ELASTIC_Q0, [0, 0, 0], parameters={"g": g, "eps": eps},
                                     h=0.1, t_end=1)
    assert ens.members == 2 and ens.parameters["g"].tolist() == [g, g]
    for i in range(2):
        single = raydamp.integrate(ElasticPendulum(g=g, eps=eps[i]), ELASTIC_Q0, [0, 0, 0], h=0.1, t_end=1)
        assert same(ens.member(i), single), i


def test_member_counts_that_disagree_name_the_parameter():
    with pytest.raises(ValueError, match=r"parameters\.eps must have shape \(3,\), got \(2,\)"):
        raydamp.integrate_ensemble(ElasticPendulum(), ELASTIC_Q0, [0, 0, 0], h=0.1, t_end=1,
                                   parameters={"g": [[0, 0, -1]] * 3, "eps": [0.1, 0.2]})
