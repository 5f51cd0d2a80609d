"""The paper's numerical experiments, as functions returning data and measured numbers.

Each function returns a plain dict: arrays for the figures and scalars that the
claims in claims.py compare against the paper. Tests call the same functions.
"""

from __future__ import annotations

import numpy as np

from ..analysis import (
    convergence,
    distance_from,
    energy_error,
    modified_energy,
    modified_relative_equilibrium,
    reduced_coordinates,
    reduced_hessian,
    reference_solution,
    relative_equilibrium,
)
from ..analysis.convergence import fitted_order
from ..analysis.relative_equilibrium import equilibrium_residual
from ..run.integrate import integrate
from ..systems.models import DampedPendulum, ElasticPendulum
from .settings import (
    ELASTIC_P0,
    ELASTIC_Q0,
    EQUILIBRIUM_P0,
    EQUILIBRIUM_Q0,
    PENDULUM_EPS,
    PENDULUM_P0,
    PENDULUM_Q0,
    SPLITTINGS,
    Settings,
)


def _linear_trend(t, y) -> float:
    """Slope of the least-squares line through (t, y)."""
    return float(np.polyfit(t, y, 1)[0])


def pendulum_phase(s: Settings) -> dict:
    """Figures 1 and 2: phase portraits over [0, T] for several h; the final energy is
    the size of the 'hole' the paper points at."""
    model = DampedPendulum(PENDULUM_EPS)
    runs = {(m, h): integrate(model, PENDULUM_Q0, PENDULUM_P0, method=m, h=h, t_end=s.pendulum_t_end)
            for m in (*SPLITTINGS, "heun") for h in s.pendulum_hs}
    ref = reference_solution(model, PENDULUM_Q0, PENDULUM_P0, [0.0, s.pendulum_t_end])

    def spread(method):
        final = np.array([runs[method, h].final_energy for h in s.pendulum_hs])
        return float(np.ptp(final) / final.mean())

    reference = float(ref.energy[-1])
    return {"runs": runs, "reference_final_energy": reference,
            "final_energy_spread": {m: spread(m) for m in (*SPLITTINGS, "heun")},
            # energy Heun failed to dissipate, relative to what the exact flow dissipates, per h
            "heun_missing_dissipation": {h: (runs["heun", h].final_energy - reference) / (ref.energy[0] - reference)
                                         for h in s.pendulum_hs}}


PAIRS = (("3s", "2s"), ("2s", "rks"), ("3s", "rks"))


def _energy_runs(eps: float, h: float, t_end: float, methods=(*SPLITTINGS, "heun")) -> dict:
    """The damped pendulum by each method, the energy errors against DOP853, the
    pairwise energy differences of the splittings and error / difference per pair."""
    model = DampedPendulum(eps)
    runs = {m: integrate(model, PENDULUM_Q0, PENDULUM_P0, method=m, h=h, t_end=t_end) for m in methods}
    t = runs["3s"].t
    ref = reference_solution(model, PENDULUM_Q0, PENDULUM_P0, t)
    errors = {m: energy_error(model, sol, ref) for m, sol in runs.items()}
    differences = {f"{a}-{b}": np.abs(runs[a].energy - runs[b].energy) for a, b in PAIRS}
    largest_error = max(np.abs(errors[m]).max() for m in SPLITTINGS)
    ratio = {k: float(largest_error / d.max()) for k, d in differences.items()}
    return {"t": t, "runs": runs, "errors": errors, "differences": differences, "ratio": ratio}


def pendulum_energy(s: Settings, h: float = 0.2) -> dict:
    """Figure 3: energy error against a DOP853 reference, and the pairwise energy
    differences between the splitting methods; the error / difference ratios also at
    eps = 1e-3 and 1e-1 and at h / 2, for their dependence on eps and h."""
    main = _energy_runs(PENDULUM_EPS, h, s.pendulum_t_end)
    t, errors = main["t"], main["errors"]
    half = t.size // 2
    growth = {m: float(np.abs(e[half:]).max() / np.abs(e[:half]).max()) for m, e in errors.items()}
    trend = {m: _linear_trend(t, np.abs(e)) * t[-1] / np.abs(e).max() for m, e in errors.items()}
    ratios = {(PENDULUM_EPS, h): main["ratio"]}
    for eps, h_other in ((1e-3, h), (1e-1, h), (PENDULUM_EPS, h / 2)):
        ratios[eps, h_other] = _energy_runs(eps, h_other, s.pendulum_t_end, SPLITTINGS)["ratio"]
    # Heun's error as the paper's "grows linearly": a straight line through it, and
    # how much of its variation the line explains.
    heun = errors["heun"]
    fit = np.polyfit(t, heun, 1)
    residual = heun - np.polyval(fit, t)
    rising = t <= t[np.argmax(np.abs(heun))]
    rising_residual = heun[rising] - np.polyval(np.polyfit(t[rising], heun[rising], 1), t[rising])
    return {"h": h, "t": t, "errors": errors, "differences": main["differences"], "growth": growth, "trend": trend,
            "difference_ratio": main["ratio"], "ratios": ratios,
            "heun_fit": {"slope": float(fit[0]), "r2": float(1.0 - residual.var() / heun.var()),
                         "r2_to_peak": float(1.0 - rising_residual.var() / heun[rising].var()),
                         "peak_time": float(t[np.argmax(np.abs(heun))]), "peak": float(np.abs(heun).max()),
                         "final": float(heun[-1])}}


def elastic_energy(s: Settings) -> dict:
    """Figure 4: energy against time for several h, eps = 0.01 and 0.1."""
    out = {}
    for eps in (0.01, 0.1):
        model = ElasticPendulum(eps)
        runs = {(m, h): integrate(model, ELASTIC_Q0, ELASTIC_P0, method=m, h=h, t_end=s.elastic_t_end)
                for m in (*SPLITTINGS, "heun") for h in s.elastic_hs}
        ref = reference_solution(model, ELASTIC_Q0, ELASTIC_P0, [0.0, s.elastic_t_end])
        rates = {m: np.array([runs[m, h].mean_dissipation_rate for h in s.elastic_hs]) for m in (*SPLITTINGS, "heun")}
        exact_rate = (ref.energy[0] - ref.energy[-1]) / s.elastic_t_end
        out[eps] = {"runs": runs, "exact_rate": float(exact_rate),
                    "rate_error": {m: float(np.abs(r - exact_rate).max() / exact_rate) for m, r in rates.items()},
                    "heun_energy_gain": float(max(runs["heun", h].final_energy - runs["heun", h].initial_energy
                                                  for h in s.elastic_hs))}
    return out


def _radius_windows(sol, windows=10):
    rho = np.hypot(sol.q[:, 0], sol.q[:, 1])
    parts = np.array_split(rho, windows)
    return np.array([w.mean() for w in parts]), np.array([np.ptp(w) for w in parts])


def _heun_drift(s: Settings) -> dict:
    """Heun's outward drift over a long run (eps = 0.1, h = 0.1): means of the radius
    over windows of 100 time units after the first, a straight line and an exponential
    rho = c exp(lambda t) fitted to them, and the growth rate early and late."""
    sol = integrate(ElasticPendulum(0.1), ELASTIC_Q0, ELASTIC_P0, method="heun", h=0.1, t_end=s.heun_drift_t_end)
    windows = int(round(s.heun_drift_t_end / 100.0))
    mean, _ = _radius_windows(sol, windows)
    times = (np.arange(windows) + 0.5) * s.heun_drift_t_end / windows
    t, rho = times[1:], mean[1:]  # the first window still holds the transient
    line = np.polyfit(t, rho, 1)
    expo = np.polyfit(t, np.log(rho), 1)
    quarter = max(2, t.size // 4)
    early = _linear_trend(t[:quarter], rho[:quarter])
    late = _linear_trend(t[-quarter:], rho[-quarter:])
    return {"t": t, "rho": rho, "t_end": s.heun_drift_t_end, "increasing": bool(np.all(np.diff(rho) > 0)),
            "rate_early": early, "rate_late": late, "lambda": float(expo[0]),
            "line_residual": float(np.sqrt(np.mean((rho - np.polyval(line, t)) ** 2))),
            "exp_residual": float(np.sqrt(np.mean((rho - np.exp(np.polyval(expo, t))) ** 2)))}


def elastic_orbits(s: Settings) -> dict:
    """Figure 5: x-y projections; Heun's radius keeps growing, the splittings settle
    on a limit cycle (for eps = 0.01 slowly: a band that narrows)."""
    runs = {}
    for eps, h, methods in ((0.1, 0.1, (*SPLITTINGS, "heun")), (0.01, 0.1, SPLITTINGS), (0.01, 0.4, SPLITTINGS)):
        model = ElasticPendulum(eps)
        for m in methods:
            runs[m, eps, h] = integrate(model, ELASTIC_Q0, ELASTIC_P0, method=m, h=h, t_end=s.orbit_t_end)
    heun_mean, _ = _radius_windows(runs["heun", 0.1, 0.1])
    split_mean, split_ptp = _radius_windows(runs["3s", 0.1, 0.1])
    window_times = np.linspace(0.0, s.orbit_t_end, heun_mean.size + 1)[1:]
    # eps = 0.01: peak-to-peak of the radius per window, each splitting, h = 0.1 and 0.4
    bands = {(m, h): _radius_windows(runs[m, 0.01, h])[1] for m in SPLITTINGS for h in (0.1, 0.4)}
    return {"runs": runs, "heun_radius_growth": float(heun_mean[-1] - heun_mean[1]),
            # after the first window's transient
            "heun_radius_trend": _linear_trend(window_times[1:], heun_mean[1:]),
            "heun_radius_increasing": bool(np.all(np.diff(heun_mean[1:]) > 0)),
            "splitting_radius_ptp_last": float(split_ptp[-1]), "splitting_radius_ptp_first": float(split_ptp[0]),
            "splitting_radius_change_late": float(abs(split_mean[-1] - split_mean[-2])),
            "bands": bands, "heun_drift": _heun_drift(s)}


def momentum(s: Settings, steps: int = 100_000) -> dict:
    """Section 5 and 6.2: J3 over 10^5 steps at h = 0.1, eps = 0.1."""
    model = ElasticPendulum(0.1)
    drift = {m: integrate(model, ELASTIC_Q0, ELASTIC_P0, method=m, h=0.1, n_steps=steps,
                          save_every=steps).max_momentum_drift for m in (*SPLITTINGS, "rksb", "heun")}
    j0 = float(model.momenta(ELASTIC_Q0, ELASTIC_P0)[0])
    return {"steps": steps, "drift": drift, "j0": j0}


def equilibrium(s: Settings, eps: float = 0.1) -> dict:
    """Figure 6: started on the exact relative equilibrium, the splittings drift to
    their modified relative equilibrium, O(h^2) away."""
    mu = float(reduced_coordinates(EQUILIBRIUM_Q0, EQUILIBRIUM_P0)[0, 4])
    rho0, z0 = EQUILIBRIUM_Q0[1], EQUILIBRIUM_Q0[2]
    residual_k1 = equilibrium_residual(ElasticPendulum(eps, k=1.0), rho0, z0, mu)
    model = ElasticPendulum(eps, k=10.0)
    residual_k10 = equilibrium_residual(model, rho0, z0, mu)
    exact = relative_equilibrium(model, mu)
    offsets = {m: np.array([np.linalg.norm(modified_relative_equilibrium(model, m, h, mu).reduced - exact.reduced)
                            for h in s.equilibrium_hs]) for m in SPLITTINGS}
    h_plot = 0.1
    modified = modified_relative_equilibrium(model, "3s", h_plot, mu)
    runs = {m: integrate(model, EQUILIBRIUM_Q0, EQUILIBRIUM_P0, method=m, h=h_plot, t_end=s.equilibrium_t_end)
            for m in SPLITTINGS}
    sol = runs["3s"]
    # "the results between the methods are inseparable": the methods' trajectories in the
    # reduced coordinates (the shape of the orbit; the phase along it is a symmetry
    # direction and not part of the figure), against their distance to the exact RE.
    reduced = {m: reduced_coordinates(r.q, r.p)[:, :4] for m, r in runs.items()}
    between = {f"{a}-{b}": float(np.linalg.norm(reduced[a] - reduced[b], axis=1).max()) for a, b in PAIRS}
    to_exact = {m: float(distance_from(exact, r).max()) for m, r in runs.items()}
    # Theorem 6.2 needs the reduced Hamiltonian strictly convex at the equilibrium.
    hessian = {"exact": np.linalg.eigvalsh(reduced_hessian(model, exact)),
               "modified 3s": np.linalg.eigvalsh(reduced_hessian(model, modified))}
    return {"mu": mu, "residual_k1": residual_k1, "residual_k10": residual_k10, "exact": exact,
            "modified": modified, "hs": np.array(s.equilibrium_hs), "offsets": offsets,
            "offset_order": {m: fitted_order(s.equilibrium_hs, o) for m, o in offsets.items()},
            "runs": runs, "h": h_plot, "between_methods": between, "max_distance_to_exact": to_exact,
            "hessian_eigenvalues": hessian,
            "distance_to_exact": distance_from(exact, sol), "distance_to_modified": distance_from(modified, sol)}


def modified_energy_study(s: Settings) -> dict:
    """Section 4: SV conserves the modified energy to O(h^4) at eps = 0 while H
    oscillates at O(h^2); 3s makes it decay monotonically at small h (Theorem 4.6)."""
    out = {"hs": np.array(s.modified_energy_hs), "H_range": {}, "Hmod_range": {}}
    for name, model, q0, p0 in (("damped_pendulum", DampedPendulum(0.0), PENDULUM_Q0, PENDULUM_P0),
                                ("elastic_pendulum", ElasticPendulum(0.0), ELASTIC_Q0, ELASTIC_P0)):
        h_range, mod_range = [], []
        for h in s.modified_energy_hs:
            sol = integrate(model, q0, p0, method="sv", h=h, t_end=100.0)
            h_range.append(np.ptp(sol.energy))
            mod_range.append(np.ptp(modified_energy(model, sol.q, sol.p, h)))
            if name == "damped_pendulum" and h == s.modified_energy_hs[0]:
                out["sv_run"] = (sol, modified_energy(model, sol.q, sol.p, h))
        out["H_range"][name], out["Hmod_range"][name] = np.array(h_range), np.array(mod_range)
    out["H_order"] = {k: fitted_order(s.modified_energy_hs, v) for k, v in out["H_range"].items()}
    out["Hmod_order"] = {k: fitted_order(s.modified_energy_hs, v) for k, v in out["Hmod_range"].items()}
    # 3s with damping on the elastic pendulum: count steps where H or H_mod rises.
    model = ElasticPendulum(0.01)
    h = 0.05
    sol = integrate(model, ELASTIC_Q0, ELASTIC_P0, method="3s", h=h, t_end=s.elastic_t_end)
    hmod = modified_energy(model, sol.q, sol.p, h)
    out["decay_run"] = (sol, hmod, h)
    out["H_rises"] = int(np.sum(np.diff(sol.energy) > 0))
    out["Hmod_rises"] = int(np.sum(np.diff(hmod) > 0))
    out["steps"] = sol.steps
    return out


# Every (method, tableau) the catalogue offers, with the order the theory gives it.
CONVERGENCE_CASES = (("3s", None, 2), ("2s", None, 2), ("rks", "heun", 2), ("rks", "rk4", 2), ("rks", "midpoint", 2),
                     ("rks", "euler", 1), ("rksb", "heun", 2), ("rksb", "rk4", 2), ("rksb", "euler", 1),
                     ("heun", None, 2), ("rk4", None, 4))


def orders(s: Settings) -> dict:
    """Figure 7: global error against h at t_end for every method on both models."""
    out = {}
    for name, model, q0, p0 in (("damped_pendulum", DampedPendulum(s.convergence_eps), PENDULUM_Q0, PENDULUM_P0),
                                ("elastic_pendulum", ElasticPendulum(s.convergence_eps), ELASTIC_Q0, ELASTIC_P0)):
        ref = reference_solution(model, q0, p0, [0.0, s.convergence_t_end])
        out[name] = {(m, tab): convergence(model, m, s.convergence_hs, q0=q0, p0=p0, t_end=s.convergence_t_end,
                                           tableau=tab, reference=(ref.q[-1], ref.p[-1]))
                     for m, tab, _ in CONVERGENCE_CASES}
    return out


def _kick_drift_kick(model, q0, p0, h: float, n_steps: int) -> tuple[np.ndarray, np.ndarray]:
    """Stormer-Verlet in its kick-drift-kick form, composed here from the exact sub-flows
    (raydamp's "sv" is drift-kick-drift). Rows of the result are the states."""
    q, p = np.asarray(q0, dtype=float), np.asarray(p0, dtype=float)
    qs, ps = [q], [p]
    for _ in range(n_steps):
        q, p = model.flow("kick", q, p, h / 2)
        q, p = model.flow("drift", q, p, h)
        q, p = model.flow("kick", q, p, h / 2)
        qs.append(q)
        ps.append(p)
    return np.array(qs), np.array(ps)


def undamped_equivalence(s: Settings, steps: int = 2000) -> dict:
    """Section 3: at eps = 0 every splitting method is Stormer-Verlet: 3s, 2s and rks
    its drift-kick-drift form; rksb (kick, drift_damp_rk, kick) its kick-drift-kick
    form, which differs from drift-kick-drift by O(h^2)."""
    worst, rksb_kdk, rksb_dkd = 0.0, {"heun": 0.0, "rk4": 0.0, "euler": 0.0}, {}
    for name, model, q0, p0 in (("damped_pendulum", DampedPendulum(0.0), PENDULUM_Q0, PENDULUM_P0),
                                ("elastic_pendulum", ElasticPendulum(0.0), ELASTIC_Q0, ELASTIC_P0)):
        sv = integrate(model, q0, p0, method="sv", h=0.1, n_steps=steps)
        for m, tab in (("3s", None), ("2s", None), ("rks", "heun"), ("rks", "rk4"), ("rks", "midpoint")):
            other = integrate(model, q0, p0, method=m, tableau=tab, h=0.1, n_steps=steps)
            worst = max(worst, np.abs(other.q - sv.q).max(), np.abs(other.p - sv.p).max())
        q, p = _kick_drift_kick(model, q0, p0, 0.1, steps)
        for tab in rksb_kdk:
            b = integrate(model, q0, p0, method="rksb", tableau=tab, h=0.1, n_steps=steps)
            rksb_kdk[tab] = float(max(rksb_kdk[tab], np.abs(b.q - q).max(), np.abs(b.p - p).max()))
        # kdk against dkd over t in [0, 10]: O(h^2)
        gaps = []
        for h in (0.1, 0.05, 0.025):
            n = int(round(10.0 / h))
            a = integrate(model, q0, p0, method="rksb", h=h, n_steps=n)
            b = integrate(model, q0, p0, method="sv", h=h, n_steps=n)
            gaps.append(max(np.abs(a.q - b.q).max(), np.abs(a.p - b.p).max()))
        rksb_dkd[name] = np.array(gaps)
    return {"max_difference": float(worst), "rksb_kdk_difference": rksb_kdk, "rksb_dkd_gap": rksb_dkd,
            "rksb_dkd_order": {k: fitted_order((0.1, 0.05, 0.025), v) for k, v in rksb_dkd.items()}}


def _euler_halves(model):
    """Explicit and implicit Euler for the q-frozen field p' = -grad V(q) - eps D(q) M^{-1} p
    (linear in p), written here in NumPy: the pieces of the paper's remark in section 3."""
    core, n = model._core_model, model.dim

    def damping_matrix(q):  # eps D(q) M^{-1}, column by column (the field is linear in p)
        return np.column_stack([np.asarray(core.damping_rate(q, e)).reshape(n) for e in np.eye(n)])

    def explicit(q, p, t):
        return q, p + t * (-model.gradient(q) - damping_matrix(q) @ p)

    def implicit(q, p, t):
        return q, np.linalg.solve(np.eye(n) + t * damping_matrix(q), p - t * model.gradient(q))

    return explicit, implicit


def conjugacy(s: Settings, steps: int = 200) -> dict:
    """The remark after Algorithm RKS: with the implicit midpoint rule M = E_{h/2} o I_{h/2}
    (E, I explicit and implicit Euler), RKS = D_{h/2} o E o I o D_{h/2} (right to left)
    is conjugate, by A = I_{h/2} o D_{h/2}, to Psi = I_{h/2} o D_h o E_{h/2}, the
    Stormer-Verlet extension the remark names: RKS^n = A^{-1} o Psi^n o A.

    Measured: rks/midpoint from raydamp against A^{-1} Psi^n A z0 composed here, and, for
    contrast, the same with the Lobatto IIIA-IIIB pair written out as a partitioned RK
    method (for q' = M^{-1} p it is E_{h/2} o D_h o I_{h/2}: implicit half step first)."""
    out = {}
    for name, model, q0, p0 in (("damped_pendulum", DampedPendulum(0.1), PENDULUM_Q0, PENDULUM_P0),
                                ("elastic_pendulum", ElasticPendulum(0.1), ELASTIC_Q0, ELASTIC_P0)):
        explicit, implicit = _euler_halves(model)

        def drift(q, p, t, model=model):
            return model.flow("drift", q, p, t)

        for h in (0.1, 0.05):
            rks = integrate(model, q0, p0, method="rks", tableau="midpoint", h=h, n_steps=steps)
            q_a, p_a = implicit(*drift(np.asarray(q0, float), np.asarray(p0, float), h / 2), h / 2)
            for label, first, last in (("paper", explicit, implicit), ("lobatto_iiia_iiib", implicit, explicit)):
                q, p, worst = q_a, p_a, 0.0
                for k in range(steps):
                    q, p = last(*drift(*first(q, p, h / 2), h), h / 2)
                    qb, pb = drift(*explicit(q, p, -h / 2), -h / 2)  # A^{-1}
                    worst = max(worst, np.abs(qb - rks.q[k + 1]).max(), np.abs(pb - rks.p[k + 1]).max())
                out[name, label, h] = float(worst)
    return {"steps": steps, "deviation": out}


def dissipation_rate(s: Settings) -> dict:
    """Theorem 4.3: up to an exponentially small remainder, the modified Hamiltonian
    loses energy at the exact rate to within O(eps h^r), r = 2 here.

    The balance B(t) = H_mod(t) - H_mod(0) + W(t) (H_mod the Stormer-Verlet modified
    Hamiltonian truncated after h^2, W the damping work) is zero for the exact rate.
    Its least-squares trend over [0, T], times T and divided by eps h^2, must stay
    bounded independently of eps and h. At eps = 0 (W = 0) the truncation alone is
    left, and it is O(h^4). (H itself would not do: its own O(h^2) oscillation hides
    the eps dependence; see the issue-11 notes in the report.)"""
    t_end = s.rate_t_end
    scaled, undamped, undamped_trend = {}, {}, {}
    for name, make, q0, p0 in (("damped_pendulum", DampedPendulum, PENDULUM_Q0, PENDULUM_P0),
                               ("elastic_pendulum", ElasticPendulum, ELASTIC_Q0, ELASTIC_P0)):
        for m in SPLITTINGS:
            for eps in s.rate_eps:
                model = make(eps)
                for h in s.rate_hs:
                    sol = integrate(model, q0, p0, method=m, h=h, t_end=t_end, work=True)
                    hmod = modified_energy(model, sol.q, sol.p, h)
                    balance = hmod - hmod[0] + sol.work
                    scaled[name, m, eps, h] = _linear_trend(sol.t, balance) * t_end / (eps * h * h)
        model, ranges, trends = make(0.0), [], []
        for h in s.rate_hs:
            sol = integrate(model, q0, p0, method="sv", h=h, t_end=t_end)
            hmod = modified_energy(model, sol.q, sol.p, h)
            ranges.append(np.abs(hmod - hmod[0]).max())
            trends.append(abs(_linear_trend(sol.t, hmod)) * t_end)
        undamped[name] = np.array(ranges)
        undamped_trend[name] = np.array(trends)
    groups = {(name, m): np.array([[scaled[name, m, eps, h] for h in s.rate_hs] for eps in s.rate_eps])
              for name, m, _, _ in scaled}
    return {"t_end": t_end, "eps": np.array(s.rate_eps), "hs": np.array(s.rate_hs), "scaled": groups,
            # spread across h at each eps, and across everything: 1 means exactly eps h^2
            "h_spread": {k: float((g.max(axis=1) / g.min(axis=1)).max()) for k, g in groups.items()},
            "spread": {k: float(g.max() / g.min()) for k, g in groups.items()},
            "undamped": undamped,
            "undamped_order": {k: fitted_order(s.rate_hs, v) for k, v in undamped.items()},
            "undamped_trend": undamped_trend,
            "undamped_trend_order": {k: fitted_order(s.rate_hs, v) for k, v in undamped_trend.items()}}


# Proposition 3.1's test system in coordinates q = (x, y): a pendulum coupled by a
# spring to a quartic oscillator, a dense mass matrix, and damping either a constant
# matrix D or one dashpot on a nonlinear g(q) (then D(q) = grad g grad g^T varies with q).
INVARIANCE_POTENTIAL = "1 - cos({x}) + ({x} - {y})^2/2 + {y}^4/4"
INVARIANCE_DAMPER = "sin({x}) + {y}^2/2"
INVARIANCE_MASS = np.array([[2.0, 0.3], [0.3, 1.0]])
INVARIANCE_DAMPING = np.array([[0.5, 0.1], [0.1, 0.2]])
INVARIANCE_A = np.array([[1.0, 0.5], [-0.3, 2.0]])  # s = A q
INVARIANCE_METHODS = (("3s", None), ("2s", None), ("rks", "heun"), ("rks", "midpoint"), ("rks", "rk4"),
                      ("rksb", "heun"), ("heun", None), ("rk4", None))


def _invariance_pair(damping: str, eps: float = 0.1):
    """The test system as a raydamp.System in q, and pulled back to s = A q: V(A^-1 s),
    M_s = A^-T M A^-1, D_s = A^-T D A^-1 (for the dashpot, g(A^-1 s), whose gradient
    carries the same A^-T)."""
    from ..systems.system import System

    a_inv = np.linalg.inv(INVARIANCE_A)
    in_q = {"x": "x", "y": "y"}
    in_s = {"x": "(b00*s0 + b01*s1)", "y": "(b10*s0 + b11*s1)"}  # q = A^-1 s
    inverse = {f"b{i}{j}": float(a_inv[i, j]) for i in range(2) for j in range(2)}
    if damping == "matrix":
        d_q = {"matrix": INVARIANCE_DAMPING.tolist()}
        d_s = {"matrix": (a_inv.T @ INVARIANCE_DAMPING @ a_inv).tolist()}
    else:
        d_q = {"dampers": [{"on": INVARIANCE_DAMPER.format(**in_q), "c": 1.0}]}
        d_s = {"dampers": [{"on": INVARIANCE_DAMPER.format(**in_s), "c": 1.0}]}
    system_q = System(["x", "y"], INVARIANCE_POTENTIAL.format(**in_q), mass=INVARIANCE_MASS.tolist(), damping=d_q,
                      eps=eps)
    system_s = System(["s0", "s1"], INVARIANCE_POTENTIAL.format(**in_s), parameters=inverse,
                      mass=(a_inv.T @ INVARIANCE_MASS @ a_inv).tolist(), damping=d_s, eps=eps)
    return system_q, system_s


def coordinate_invariance(s: Settings, h: float = 0.05, t_end: float = 20.0) -> dict:
    """Proposition 3.1 for linear changes of coordinates s = A q: integrate in q and in s
    (M, D, V pulled back; momenta r = A^-T p, the cotangent lift) and map one trajectory
    onto the other. Every method maps, Runge-Kutta ones too: a linear change of q with
    its cotangent lift is linear in (q, p), and Runge-Kutta methods are affine covariant.
    What sets the splittings apart is nonlinear changes (q-dependent mass), which
    raydamp.System (constant M) cannot express."""
    a = INVARIANCE_A
    a_inv = np.linalg.inv(a)
    q0, p0 = np.array([1.0, -0.5]), np.array([0.2, 0.7])
    deviation, scale = {}, 0.0
    for damping in ("matrix", "dampers"):
        system_q, system_s = _invariance_pair(damping)
        for m, tab in INVARIANCE_METHODS:
            in_q = integrate(system_q, q0, p0, method=m, tableau=tab, h=h, t_end=t_end)
            in_s = integrate(system_s, a @ q0, a_inv.T @ p0, method=m, tableau=tab, h=h, t_end=t_end)
            deviation[damping, m if tab is None else f"{m}/{tab}"] = float(max(
                np.abs(in_s.q - in_q.q @ a.T).max(), np.abs(in_s.p - in_q.p @ a_inv).max()))
            scale = max(scale, float(np.abs(in_q.q).max()), float(np.abs(in_q.p).max()))
    return {"deviation": deviation, "steps": int(round(t_end / h)), "h": h, "scale": scale}
