"""Compositions of the symmetric splittings (issue 8): orders 4, 4, 6, 8, 8 with eps > 0 on
both paper models and a user System, momentum maps kept, the amplification guard."""

from __future__ import annotations

import functools
import math
import re

import numpy as np
import pytest
import systems
from paper import fitted_slope, paper_problem, reference

import raydamp

COMPOSITIONS = [("yoshida4", 4), ("suzuki4", 4), ("kahan_li6", 6), ("mclachlan8", 8), ("kahan_li8", 8)]
BASES = [("3s", None), ("2s", None), ("rks", "midpoint")]
T = 10.0
SAVES = 5  # the error is the max over the states at t = 2, 4, ..., 10 (a single time can sit
            # near a zero of the error and bend the fit)
# Steps per run, by order: the asymptotic range where errors stay well above the
# reference's (about 1e-13 here; 2e-12 for the chain's modal damping flows).
STEPS = {4: [40, 60, 80, 120], 6: [30, 40, 60, 80], 8: [40, 60, 80]}
STEPS_PENDULUM_8 = [30, 40, 60]  # its order-8 errors reach the floor sooner
REFERENCE_STEPS = 640  # kahan_li8 over 2s: error about (60/640)^8 below the smallest measured one


def problem(name: str, eps: float):
    if name == "chain":  # three masses, two dashpots that do not commute, a quartic spring
        return systems.chain(eps=eps), [0.5, -0.3, 0.8], [0.0, 0.4, -0.2]
    return paper_problem(name, eps)


EPS = {"damped_pendulum": 0.5, "elastic_pendulum": 0.5, "chain": 0.2}


def trajectory(model, q0, p0, n: int, method: str = "2s", tableau=None, composition=None, span: float = T):
    sol = raydamp.integrate(model, q0, p0, method=method, tableau=tableau, composition=composition, h=span / n,
                            t_end=span, save_every=n // SAVES)
    assert sol.success and sol.t.size == SAVES + 1 and sol.t[-1] == pytest.approx(span, abs=1e-12)
    return np.hstack([sol.q, sol.p])


@functools.cache
def reference_trajectory(name: str, eps: float, span: float = T) -> np.ndarray:
    model, q0, p0 = problem(name, eps)
    return trajectory(model, q0, p0, REFERENCE_STEPS, composition="kahan_li8", span=span)


@pytest.mark.parametrize("name", ["damped_pendulum", "elastic_pendulum", "chain"])
def test_reference_agrees_with_dop853(name):
    # The composed reference is itself checked against an independent solver.
    model, q0, p0 = problem(name, EPS[name])
    q, p = reference(model.vector_field, np.array(q0), np.array(p0), T)
    assert np.abs(np.concatenate([q, p]) - reference_trajectory(name, EPS[name])[-1]).max() < 5e-12


def measured_order(name: str, eps: float, method: str, tableau, composition: str, steps, span: float = T):
    model, q0, p0 = problem(name, eps)
    ref = reference_trajectory(name, eps, span)
    errors = [np.abs(trajectory(model, q0, p0, n, method, tableau, composition, span) - ref).max() for n in steps]
    return fitted_slope([span / n for n in steps], errors), errors


@pytest.mark.parametrize(("composition", "order"), COMPOSITIONS)
@pytest.mark.parametrize(("method", "tableau"), BASES)
@pytest.mark.parametrize("name", ["damped_pendulum", "elastic_pendulum", "chain"])
def test_order_with_damping(name, method, tableau, composition, order):
    steps = STEPS_PENDULUM_8 if (name == "damped_pendulum" and order == 8) else STEPS[order]
    slope, errors = measured_order(name, EPS[name], method, tableau, composition, steps)
    assert slope == pytest.approx(order, abs=0.1), errors


@pytest.mark.parametrize(("composition", "order"), COMPOSITIONS)
@pytest.mark.parametrize("name", ["damped_pendulum", "elastic_pendulum"])
def test_stormer_verlet_compositions_undamped(name, composition, order):
    # sv refuses eps > 0, so its compositions are measured at eps = 0, over t <= 5: undamped,
    # the pendulum swinging near its top stays far from the asymptotic range longer.
    steps = [20, 25, 30] if order == 8 else STEPS[order]
    slope, errors = measured_order(name, 0.0, "sv", None, composition, steps, span=5.0)
    assert slope == pytest.approx(order, abs=0.1), errors


def test_catalogue():
    listed = {c.name: c for c in raydamp.compositions()}
    assert {name: listed[name].order for name, _ in COMPOSITIONS} == dict(COMPOSITIONS)
    assert [listed[n].stages for n in ("none", "yoshida4", "suzuki4", "kahan_li6", "mclachlan8", "kahan_li8")] == \
        [1, 3, 5, 9, 15, 17]
    for c in listed.values():
        assert math.fsum(c.gammas) == pytest.approx(1.0, abs=1e-15)
        assert c.gammas == c.gammas[::-1]
    # The triple jump's middle coefficient is derived: -2^{1/3} / (2 - 2^{1/3}).
    assert listed["yoshida4"].gammas[1] == pytest.approx(-2 ** (1 / 3) / (2 - 2 ** (1 / 3)), rel=1e-15)
    symmetric = {(m.name, m.tableau) for m in raydamp.methods() if m.symmetric}
    assert symmetric == {("sv", None), ("3s", None), ("baoab", None), ("2s", None), ("rks", "midpoint"),
                         ("midpoint", None)}


def test_solution_records_the_composition():
    model, q0, p0 = paper_problem("elastic_pendulum", 0.1)
    sol = raydamp.integrate(model, q0, p0, method="3s", composition="suzuki4", h=0.1, n_steps=10)
    assert sol.composition == "suzuki4" and sol.summary()["composition"] == "suzuki4"
    assert raydamp.integrate(model, q0, p0, method="3s", h=0.1, n_steps=10).composition is None


def test_composition_none_is_the_base_step():
    model, q0, p0 = paper_problem("elastic_pendulum", 0.3)
    plain = raydamp.integrate(model, q0, p0, method="2s", h=0.1, n_steps=100)
    none = raydamp.integrate(model, q0, p0, method="2s", composition="none", h=0.1, n_steps=100)
    assert np.array_equal(plain.q, none.q) and np.array_equal(plain.p, none.p)


@pytest.mark.parametrize(("method", "tableau", "composition"), [
    ("rks", "heun", "yoshida4"), ("rks", None, "kahan_li6"), ("rksb", "heun", "suzuki4"), ("heun", None, "yoshida4"),
    ("rk4", None, "yoshida4"), ("3s", None, "yoshida6"), ("3s", None, 4)])
def test_refused_compositions_name_the_argument(method, tableau, composition):
    model, q0, p0 = paper_problem("damped_pendulum", 0.1)
    with pytest.raises(ValueError, match="^composition"):
        raydamp.integrate(model, q0, p0, method=method, tableau=tableau, composition=composition, h=0.1, n_steps=10)


@pytest.mark.parametrize(("method", "tableau"), BASES)
@pytest.mark.parametrize("composition", ["yoshida4", "kahan_li6", "kahan_li8"])
def test_momentum_map_conserved_by_compositions(method, tableau, composition):
    # Kepler orbit with a radial dashpot: the angular momentum is conserved by every
    # sub-flow of 3s, 2s and rks (paper section 5), so by their compositions too.
    model = systems.kepler(eps=0.05)
    sol = raydamp.integrate(model, [1.0, 0.0], [0.0, 1.2], method=method, tableau=tableau, composition=composition,
                            h=0.05, n_steps=4000, save_every=100)
    assert sol.success
    assert sol.max_momentum_drift < 1e-13
    assert np.abs(sol.momentum - 1.2).max() < 1e-13


# ---- The amplification guard.

def stiff_structure(beta: float = 0.1) -> raydamp.System:
    """Two springs of stiffness 1000 and 1 with stiffness-proportional (beta) damping D = beta K:
    the stiff mode's damping rate is eps beta 1000 = 100."""
    return raydamp.System(["a", "b"], "(1000*a^2 + b^2)/2", damping={"matrix": [[1000 * beta, 0.0], [0.0, beta]]},
                          eps=1.0)


def test_guard_refuses_a_stiff_structure_at_order_4_and_accepts_order_2():
    model = stiff_structure()
    q0, p0 = [0.01, 1.0], [0.0, 0.0]
    with pytest.raises(ValueError) as refused:
        raydamp.integrate(model, q0, p0, method="2s", composition="yoshida4", h=0.05, n_steps=10)
    message = str(refused.value)
    # 2s runs kick+damp for gamma_2 h = -1.70 * 0.05: e^{0.0851 * 100} = 4.97e3.
    assert message.startswith("composition: 'yoshida4'") and "h = 0.05" in message
    assert "4.97e+03" in message and "rho = 100" in message and "composition=None" in message
    suggested = float(message.rsplit("h <= ", 1)[1])
    assert suggested == pytest.approx(math.log(10) / (100 * 1.7024143839193153), rel=2e-3)
    # Accepted at order 2, and at the suggested h.
    assert raydamp.integrate(model, q0, p0, method="2s", h=0.05, n_steps=10).success
    assert raydamp.integrate(model, q0, p0, method="2s", composition="yoshida4", h=0.99 * suggested,
                             n_steps=10).success


def test_guard_limit_is_the_documented_one():
    from raydamp.run.integrate import MAX_AMPLIFICATION

    assert MAX_AMPLIFICATION == 10.0


def test_guard_passes_mild_damping():
    # The paper's models at their usual eps and h are far from the limit.
    for name in ("damped_pendulum", "elastic_pendulum"):
        model, q0, p0 = paper_problem(name, 0.5)
        for composition, _ in COMPOSITIONS:
            assert raydamp.integrate(model, q0, p0, method="2s", composition=composition, h=0.5, n_steps=4).success


def test_guard_sees_the_implicit_midpoint_pole():
    # rks(midpoint) backward: R(z) = (1 + z/2)/(1 - z/2) has a pole at z = 2, where e^z is only 7.4.
    model = raydamp.System(["a"], "a^2/2", damping={"scalar": 1.0}, eps=2.0)  # rho = 2
    h = 2.0 / (2 * 1.7024143839193153 * 1.0) * 0.999  # the backward RK sub-step at z just under 2
    with pytest.raises(ValueError, match="^composition: 'yoshida4'"):
        raydamp.integrate(model, [1.0], [0.0], method="rks", tableau="midpoint", composition="yoshida4", h=h,
                          n_steps=4)
    # The exact backward flow of 2s at the same h amplifies by e^{1.998} = 7.4 only: accepted.
    assert raydamp.integrate(model, [1.0], [0.0], method="2s", composition="yoshida4", h=h, n_steps=4).success


# ---- Issue 28: the guard's bound holds where the spectrum is only estimated, and its message
# evaluates the formula it quotes.

def consistent_bar(n: int = 200):
    """A bar of n linear elements (length 1, EA = rho A = 1), fixed at x = 0: consistent M and K."""
    import scipy.sparse as sp

    size = 1.0 / n
    main = np.full(n, 2.0)
    main[-1] = 1.0  # the free end belongs to one element
    off = np.ones(n - 1)
    K = sp.diags([main, -off, -off], [0, 1, -1]) / size
    M = sp.diags([2.0 * main, off, off], [0, 1, -1]) * (size / 6.0)
    return M.tocsc(), K.tocsc()


def gammas(name: str) -> np.ndarray:
    return np.array(next(c.gammas for c in raydamp.compositions() if c.name == name))


def test_guard_bound_holds_on_a_200_dof_consistent_mass_bar():
    # 200 DOF, Rayleigh C = 0.1 M + 1e-4 K: the damping rates alpha + beta omega^2 reach 48.1. The
    # guard once estimated rho by power iteration that stopped 0.12% low here, accepting an h at
    # which a backward sub-step amplified the top mode by 10.03; it now takes the structure's
    # guaranteed bound alpha + beta L (L from Lanczos with its residual, times 1.05).
    import scipy.linalg

    M, K = consistent_bar(200)
    alpha, beta = 0.1, 1e-4
    bar = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    omega2, modes = scipy.linalg.eigh(K.toarray(), M.toarray())  # dense reference: K v = omega^2 M v
    rates = alpha + beta * omega2  # the eigenvalues of A = C M^{-1}
    assert bar.damping_rate_bound >= rates.max()
    zero = np.zeros(200)

    def accepted(h: float) -> bool:
        try:
            raydamp.integrate(bar, zero, zero, method="3s", composition="kahan_li8", h=h, n_steps=1)
        except ValueError as refused:
            assert str(refused).startswith("composition: 'kahan_li8'")
            return False
        return True

    lo, hi = 0.0, 1.0  # the largest h integrate accepts, to 2^-40 relative
    assert not accepted(hi)
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if accepted(mid) else (lo, mid)
    # 3s's backward damping sub-steps: the merged (gamma_i + gamma_{i+1}) h / 2 between stages.
    g = gammas("kahan_li8")
    c = min(((g[:-1] + g[1:]) / 2).min(), g[0] / 2)
    assert c == pytest.approx(-0.155248405, abs=1e-9)
    amplification = np.exp(-c * lo * rates).max()  # measured 8.95
    assert amplification <= raydamp.run.integrate.MAX_AMPLIFICATION
    assert amplification >= 10 ** (1 / 1.06)  # the bound's slack is Lanczos' 5% margin, no more
    assert not accepted(1.001 * lo)
    # The backward damping flow raydamp runs multiplies the top mode by that factor (to 1e-10).
    top = M @ modes[:, -1]
    _, grown = bar.flow("damp", zero, top, c * lo)
    assert np.linalg.norm(grown) / np.linalg.norm(top) == pytest.approx(amplification, rel=1e-10)


def _refusal(model, q0, p0, **options) -> str:
    with pytest.raises(ValueError) as refused:
        raydamp.integrate(model, q0, p0, n_steps=1, **options)
    return str(refused.value)


def _number(pattern: str, message: str) -> float:
    found = re.search(pattern, message)
    assert found, (pattern, message)
    return float(found.group(1))


@pytest.mark.parametrize("method, composition, coefficient", [
    ("3s", "kahan_li8", lambda g: (g[7] + g[8]) / 2),  # the merged damp joining stages 8 and 9
    ("3s", "yoshida4", lambda g: (g[0] + g[1]) / 2),
    ("2s", "yoshida4", lambda g: g[1]),  # kick+damp for gamma_2 h
])
def test_guard_message_evaluates_the_formula_on_the_coefficient_it_names(method, composition, coefficient):
    # 3s over kahan_li8 once quoted gamma = -0.606 and e^{|gamma h| rho}, with a number computed from
    # the merged -0.155 (18.4 reported where the formula as written gave 8.6e4). The message now names
    # the sub-step's coefficient c and the formula it evaluated: every number checks against them
    # (c, the exponent and rho to the 6 digits printed, the factor to its 3).
    model = stiff_structure()  # rho = 100
    message = _refusal(model, [0.01, 1.0], [0.0, 0.0], method=method, composition=composition, h=0.5)
    c = _number(r"lasts c h with c = [^=]+ = (-?[\d.]+(?:e[+-]\d+)?)", message)
    assert c == pytest.approx(coefficient(gammas(composition)), rel=1e-5)
    h = _number(r"with h = ([\d.e+-]+) ", message)
    rho = _number(r"with rho = ([\d.e+-]+) ", message)
    assert (h, rho) == (0.5, pytest.approx(100, rel=1e-12))
    exponent = _number(r"e\^\{\|c\| h rho\} = e\^\{([\d.e+-]+)\}", message)
    assert exponent == pytest.approx(abs(c) * h * rho, rel=1e-5)
    factor = _number(r"e\^\{[\d.e+-]+\} = ([\d.e+-]+) with rho", message)
    assert factor == pytest.approx(math.exp(abs(c) * h * rho), rel=5e-3)


def test_guard_message_names_the_stability_function_where_it_decides():
    # rks(midpoint) over yoshida4: the backward kick+damp runs for gamma_2 h, z = 1.7024 h rho = 1.8,
    # where R(z) = (1 + z/2)/(1 - z/2) = 19 exceeds the limit while e^z = 6.05 does not.
    model = raydamp.System(["a"], "a^2/2", damping={"scalar": 1.0}, eps=2.0)  # rho = 2
    h = 1.8 / (2 * 1.7024143839193153)
    message = _refusal(model, [1.0], [0.0], method="rks", tableau="midpoint", composition="yoshida4", h=h)
    assert "kick_damp_rk sub-step in stage 2" in message and "c = gamma_2 = -1.70241, " in message
    z = _number(r"\|R\(\|c\| h rho\)\| of tableau 'midpoint' = \|R\(([\d.e+-]+)\)\|", message)
    assert z == pytest.approx(1.8, rel=1e-5)
    factor = _number(r"\|R\([\d.e+-]+\)\| = ([\d.e+-]+) with rho", message)
    assert factor == pytest.approx((1 + z / 2) / (1 - z / 2), rel=5e-3)


def _balance_slope(model, q0, p0, method, tableau, composition, steps, **options) -> tuple[float, list[float]]:
    errors = []
    for n in steps:
        sol = raydamp.integrate(model, q0, p0, method=method, tableau=tableau, composition=composition, h=T / n,
                                t_end=T, save_every=n // SAVES, work=True, **options)
        errors.append(np.abs(sol.energy_balance).max())
    return fitted_slope([T / n for n in steps], errors), errors


@pytest.mark.parametrize(("composition", "order"), [("yoshida4", 4), ("kahan_li6", 6)])
@pytest.mark.parametrize(("method", "tableau"), BASES)
@pytest.mark.parametrize("name", ["damped_pendulum", "chain"])
def test_the_damping_work_has_the_compositions_order(name, method, tableau, composition, order):
    """The energy balance H - H0 + W of a composed run falls at the composition's order. An audit found W
    integrated by the trapezoid on the composed step's end points only: order 2 whatever the composition
    (kahan_li6 on the pendulum: a balance of 4.9e-4 at h = 0.1 where the state's error was 5e-10)."""
    model, q0, p0 = problem(name, EPS[name])
    slope, errors = _balance_slope(model, q0, p0, method, tableau, composition, STEPS[order])
    assert slope == pytest.approx(order, abs=0.3), errors


@pytest.mark.parametrize(("composition", "order"), [("yoshida4", 4), ("kahan_li6", 6)])
def test_the_load_work_has_the_compositions_order(composition, order):
    """W_f too (a harmonic load on a damped 3-mass structure): H - H0 + W - W_f falls at the order."""
    M = np.diag([1.0, 2.0, 1.5])
    K = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    structure = raydamp.LinearStructure(M, K, alpha=0.2, beta=0.05)
    load = raydamp.Load.harmonic([1.0, 0.0, 0.5], 1.3)
    slope, errors = _balance_slope(structure, [0.1, 0.0, -0.1], [0.0, 0.2, 0.0], "2s", None, composition,
                                   STEPS[order], load=load)
    assert slope == pytest.approx(order, abs=0.3), errors
