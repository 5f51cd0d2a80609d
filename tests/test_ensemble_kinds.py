"""Ensembles and sweeps of the large-system kinds (issue 8: "works for the built-in models,
Systems and the large-systems kinds alike"): Chain and LinearStructure members equal single
runs bit for bit, on threads; a System's configuration check runs once for all members."""

from __future__ import annotations

import math

import numpy as np
import pytest
import systems
from fe_plate import plate
from test_ensemble import same

import raydamp


def fput_chain(boundary: str = "fixed") -> raydamp.Chain:
    return raydamp.Chain(n=32, bond="fput", parameters={"alpha": 0.25, "beta": 1.0}, boundary=boundary,
                         dampers={"bonds": [9, 10, 19], "c": 0.1})


CHAINS = {
    "fixed": lambda: fput_chain("fixed"),
    "periodic": lambda: fput_chain("periodic"),
    # an expression bond: compiled code shared by the threads; an on-site potential; site friction
    "expression-phi4-sites": lambda: raydamp.Chain(
        n=32, bond="expression", parameters={"potential": "r^2/2 + b*r^4/4", "b": 0.5}, boundary="free",
        on_site={"kind": "phi4", "k2": -1.0, "k4": 1.0}, dampers={"sites": [3, 4, 20], "c": 0.2}),
}


@pytest.mark.parametrize("boundary", list(CHAINS))
@pytest.mark.parametrize("method,composition", [("3s", None), ("2s", None), ("3s", "yoshida4")])
def test_chain_members_equal_single_runs_bit_for_bit(boundary, method, composition):
    chain = CHAINS[boundary]()
    rng = np.random.default_rng(3)
    q0 = 0.3 * rng.standard_normal((6, 32))
    p0 = 0.3 * rng.standard_normal((6, 32))
    ens = raydamp.integrate_ensemble(chain, q0, p0, method=method, composition=composition, h=0.05, n_steps=200,
                                     save_every=30, threads=2)
    assert ens.status == ("completed",) * 6
    for i in range(6):
        ref = raydamp.integrate(chain, q0[i], p0[i], method=method, composition=composition, h=0.05, n_steps=200,
                                save_every=30)
        assert same(ens.member(i), ref), i
    # the members differ, and a periodic chain with damped bonds only keeps its momentum P
    assert len({float(e) for e in ens.energy_final}) == 6
    if boundary == "periodic":
        assert ens.momentum.shape[-1] == 1
        assert np.max(np.abs(ens.momentum[:, -1, 0] - p0.sum(axis=1))) < 1e-12


@pytest.mark.parametrize("consistent", [False, True])
def test_linear_structure_members_equal_single_runs_bit_for_bit(consistent):
    pl = plate(8, 4)  # 80 degrees of freedom
    structure = raydamp.LinearStructure(pl.M if consistent else pl.M_lumped, pl.K, alpha=0.05, beta=2e-3)
    rng = np.random.default_rng(5)
    q0 = 0.01 * rng.standard_normal((4, pl.n))
    p0 = np.zeros((4, pl.n))
    for method, tableau in (("3s", None), ("rks", "midpoint")):
        ens = raydamp.integrate_ensemble(structure, q0, p0, method=method, tableau=tableau, h=0.05, n_steps=60,
                                         save_every=20, threads=2)
        for i in range(4):
            ref = raydamp.integrate(structure, q0[i], p0[i], method=method, tableau=tableau, h=0.05, n_steps=60,
                                    save_every=20)
            assert same(ens.member(i), ref), (method, i)
        # damped: every member loses energy
        assert np.all(ens.energy_final < ens.energy[:, 0])


def test_large_kinds_take_no_per_member_parameters():
    with pytest.raises(ValueError, match=r"parameters.eps: not a parameter .*\(known: none; .*one model per value\)"):
        raydamp.integrate_ensemble(fput_chain(), np.zeros((2, 32)), np.zeros(32), parameters={"eps": [0.1, 0.2]},
                                   h=0.05, n_steps=3)
    assert raydamp.run.ensemble.member_parameters(fput_chain()) == ()


def test_system_configurations_checked_in_one_call_naming_the_first_bad_member(monkeypatch):
    # grad V and the dashpot's gradient (q/|q|) are NaN at the origin, so the member placed
    # there is refused. The compiled functions check every member at once: the per-member
    # Python check runs only for the bad one, to word its message.
    model = systems.elastic_pendulum(eps=0.1)
    calls = []
    one_member = type(model).check_configuration
    monkeypatch.setattr(type(model), "check_configuration",
                        lambda self, name, q: calls.append(name) or one_member(self, name, q))
    rng = np.random.default_rng(2)
    q0 = rng.standard_normal((5000, 3)) + 3.0
    q0[3172] = 0.0
    with pytest.raises(ValueError, match=r"q0\[3172\] = \[0.0, 0.0, 0.0\]"):
        raydamp.integrate_ensemble(model, q0, np.zeros(3), h=0.1, n_steps=2)
    assert calls == ["q0[3172]"]
    calls.clear()
    q0[3172] = 1.0
    ens = raydamp.integrate_ensemble(model, q0, np.zeros(3), h=0.1, n_steps=2)
    assert ens.status.count("completed") == 5000
    assert calls == []
    # a System built from Python functions is checked member by member, and names the member too
    direct = raydamp.System.from_functions(
        1, potential=lambda q: -math.log(q[0]), gradient=lambda q: np.array([-1.0 / q[0]]))
    with pytest.raises(ValueError, match=r"q0\[1\]"):
        direct.check_configurations("q0", np.array([[1.0], [0.0]]))
