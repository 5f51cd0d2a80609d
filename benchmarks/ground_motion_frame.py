"""The ground-motion case of bench_vs_opensees.py (issue 26): a 10-storey shear frame under a record.

The frame: storey masses 1e5 kg, storey stiffness 2e8 N/m, fixed base, lumped M, 5% Rayleigh damping
in modes 1 and 3. The record: 20 s of a synthetic accelerogram sampled at dt = 0.01 s (filtered
noise under a build-up/decay envelope, seeded, peak about 4 m/s^2), applied as uniform base
excitation: raydamp.GroundMotion (the load -M r a_g(t), r = 1) and, in OpenSees, a Path timeSeries
(-dt, -values) in pattern UniformExcitation. Both give the roof displacement relative to the
ground, compared at the record's sample times with the exact response to the piecewise-linear
record (raydamp.analysis.piecewise_linear_response: the Nigam-Jennings solution, one matrix
exponential of the system augmented with the segment's linear forcing, applied sample by sample).

For each step size (dt, dt/2, ... dt/16) it prints, side by side, each tool's error
max |u - u_exact| / max |u_exact| and its time (the analysis only: raydamp.integrate; OpenSees'
analyze, after building the model).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg

import raydamp
from raydamp.analysis import piecewise_linear_response

STOREYS, MASS, STIFFNESS, ZETA = 10, 1.0e5, 2.0e8, 0.05


def record(seconds: float = 20.0, dt: float = 0.01, seed: int = 11) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(seconds / dt)) + 1) * dt
    smooth = np.convolve(rng.standard_normal(t.size), np.ones(5) / 5, mode="same")
    envelope = np.minimum(1.0, t / 2.0) * np.exp(-np.maximum(0.0, t - 8.0) / 4.0)
    return t, 4.0 * smooth * envelope


def shear_frame_stiffness(storeys: int = STOREYS, stiffness: float = STIFFNESS) -> np.ndarray:
    """K of a shear frame of equal storeys: storey i joins floor i to the one below it, storey 0 to the ground."""
    K = np.zeros((storeys, storeys))
    for i in range(storeys):
        K[i, i] += stiffness
        if i + 1 < storeys:
            K[i, i] += stiffness
            K[i, i + 1] = K[i + 1, i] = -stiffness
    return K


def frame():
    M = np.eye(STOREYS) * MASS
    K = shear_frame_stiffness()
    w = np.sqrt(np.sort(scipy.linalg.eigh(K, M, eigvals_only=True)))
    alpha, beta = raydamp.rayleigh_coefficients(w[0], w[2], ZETA, ZETA)
    return M, K, alpha, beta, w


def exact_roof(M, C, K, t, a_g) -> np.ndarray:
    """u_roof at the sample times: the load -M r a_g(t), r = 1, a_g linear on each interval."""
    q, _ = piecewise_linear_response(M, C, K, -M @ np.ones(M.shape[0]), t, a_g)
    return q[:, -1]


def raydamp_roof(M, K, alpha, beta, t, a_g, method: str, h_factor: int):
    model = raydamp.LinearStructure(M, K, alpha=alpha, beta=beta)
    motion = raydamp.GroundMotion((t, a_g), np.ones(STOREYS))
    dt = t[1] - t[0]
    start = time.perf_counter()
    sol = raydamp.integrate(model, np.zeros(STOREYS), np.zeros(STOREYS), method=method, h=dt / h_factor,
                            t_end=float(t[-1]), save_every=h_factor, load=motion, save_dofs=[STOREYS - 1])
    seconds = time.perf_counter() - start
    assert sol.success, sol.message
    return seconds, sol.q[:, 0]


def opensees_shear_frame(ops, materials, t, a_g, mass: float = MASS) -> None:
    """The shear frame in OpenSees, up to its analysis options: nodes 0 (fixed base) .. n on one axis, each above
    the base lumping ``mass``; storey i (1..n) a uniaxial material of tag i, materials[i - 1] = (kind, *its
    parameters), in a zeroLength element from node i - 1 to i with Rayleigh damping; the record a_g (sampled at
    t) as uniform base excitation (timeSeries and pattern tag 1). The caller's ops.rayleigh follows."""
    ops.wipe()
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    storeys = len(materials)
    for i in range(storeys + 1):
        ops.node(i, 0.0)
    ops.fix(0, 1)
    for i in range(1, storeys + 1):
        ops.mass(i, mass)
    for i, (kind, *parameters) in enumerate(materials, start=1):
        ops.uniaxialMaterial(kind, i, *(float(x) for x in parameters))
        ops.element("zeroLength", i, i - 1, i, "-mat", i, "-dir", 1, "-doRayleigh", 1)
    ops.timeSeries("Path", 1, "-dt", float(t[1] - t[0]), "-values", *np.asarray(a_g, float).tolist())
    ops.pattern("UniformExcitation", 1, 1, "-accel", 1)


def opensees_roof(ops, alpha, beta, t, a_g, h_factor: int):
    opensees_shear_frame(ops, [("Elastic", STIFFNESS)] * STOREYS, t, a_g)
    ops.rayleigh(alpha, beta, 0.0, 0.0)
    dt = float(t[1] - t[0])
    ops.constraints("Plain")
    ops.numberer("RCM")
    ops.system("BandSPD")
    ops.algorithm("Linear", "-factorOnce")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    roof = [0.0]
    seconds = 0.0
    for _ in range(t.size - 1):
        start = time.perf_counter()
        if ops.analyze(h_factor, dt / h_factor) != 0:
            raise RuntimeError("OpenSees analyze failed")
        seconds += time.perf_counter() - start
        roof.append(ops.nodeDisp(STOREYS, 1))  # not timed
    ops.wipe()
    return seconds, np.array(roof)


def run(ops) -> None:
    M, K, alpha, beta, w = frame()
    t, a_g = record()
    print(f"\nground motion: {STOREYS}-storey shear frame, T1 = {2 * np.pi / w[0]:.3f} s, 5% Rayleigh in modes 1 and 3 "
          f"(alpha = {alpha:.3g}, beta = {beta:.3g}); record {t[-1]:.0f} s at dt = {t[1] - t[0]:g} s, "
          f"peak {np.max(np.abs(a_g)):.2f} m/s^2")
    start = time.perf_counter()
    exact = exact_roof(M, alpha * M + beta * K, K, t, a_g)
    peak = np.max(np.abs(exact))
    print(f"    exact reference (expm per sample interval) in {time.perf_counter() - start:.2f} s; "
          f"peak roof displacement {peak:.4g} m")
    print(f"    {'h':>9}  " + "  ".join(f"{label:>28}" for label in
                                        ("raydamp gauss4", "raydamp midpoint", "raydamp 3s", "OpenSees Newmark")))
    for factor in (1, 2, 4, 8, 16):
        cells = []
        for method in ("gauss4", "midpoint", "3s"):
            seconds, roof = min((raydamp_roof(M, K, alpha, beta, t, a_g, method, factor) for _ in range(3)),
                                key=lambda r: r[0])
            cells.append(f"{np.max(np.abs(roof - exact)) / peak:9.2e} {1e3 * seconds:9.2f} ms")
        if ops is not None:
            seconds, roof = opensees_roof(ops, alpha, beta, t, a_g, factor)
            cells.append(f"{np.max(np.abs(roof - exact)) / peak:9.2e} {1e3 * seconds:9.2f} ms")
        else:
            cells.append(f"{'(not installed)':>28}")
        print(f"    {(t[1] - t[0]) / factor:9.5f}  " + "  ".join(f"{c:>28}" for c in cells))
    print("    (error: max |u_roof - exact| / max |exact| over the 2,001 samples; time of the analysis alone)")
