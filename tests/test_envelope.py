"""Envelope recorders (issue 42): peaks taken at every step's end, per coordinate and per spring, equal to the
peaks of a trajectory saved every step; per member in an ensemble; a collapse limit that stops a run."""

import numpy as np
import pytest

import raydamp
from raydamp.materials import Bilinear, ElasticPlastic

STOREYS = 3
K_STOREY, FY = 400.0, 6.0


def frame(materials=None, **kwargs):
    """A 3-storey shear frame whose storeys are springs (storey 0 to the ground), listed top storey first so
    that the springs' order differs from the core's (which groups them by material kind)."""
    materials = materials or [Bilinear(K_STOREY, FY, 0.05), ElasticPlastic(K_STOREY, FY), Bilinear(K_STOREY, FY, 0.1)]
    springs = [raydamp.Spring((s - 1, s) if s else (0,), materials[s]) for s in reversed(range(STOREYS))]
    return raydamp.Structure(np.eye(STOREYS), springs=springs, alpha=0.2, **kwargs)


def record(seed=3, n=601, dt=0.01):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal(n) * np.sin(np.pi * np.arange(n) / (n - 1)) * 8.0
    return raydamp.GroundMotion((np.arange(n) * dt, a), np.ones(STOREYS))


def drifts(structure, q):
    """Each spring's deformation q_j - q_i (q_j to the ground) of the rows q, in the Structure's order."""
    return np.stack([q[..., s.dofs[-1]] - (q[..., s.dofs[0]] if len(s.dofs) == 2 else 0.0)
                     for s in structure.springs], axis=-1)


ALL = ["drift", "displacement", "velocity", "abs_acceleration", "force", "residual_drift", "residual_displacement"]
RUN = {"method": "3s", "h": 0.005, "t_end": 6.0}


@pytest.mark.parametrize("locate_kinks", [False, True])
def test_the_peaks_of_a_trajectory_saved_every_step_are_the_recorders_exactly(locate_kinks):
    # With kinks located the step is split where a spring's phase ends; the recorder still reads each step's end
    # (it missed every step when the two landed side by side).
    structure = frame(locate_kinks=locate_kinks)
    sol = raydamp.integrate(structure, np.zeros(3), np.zeros(3), load=record(), envelope=ALL, **RUN)
    env = sol.envelope
    assert sol.status == "completed" and sol.t.size == 1201
    d = drifts(structure, sol.q)
    k = np.argmax(np.abs(d), axis=0)
    np.testing.assert_array_equal(env["drift"].values, np.abs(d).max(axis=0))
    np.testing.assert_array_equal(env["drift_time"].values, sol.t[k])
    np.testing.assert_array_equal(env["displacement"].values, np.abs(sol.q).max(axis=0))
    np.testing.assert_array_equal(env["displacement_time"].values, sol.t[np.argmax(np.abs(sol.q), axis=0)])
    np.testing.assert_allclose(env["velocity"].values, np.abs(sol.p).max(axis=0), rtol=1e-15)  # M = I
    np.testing.assert_array_equal(env["residual_drift"].values, d[-1])
    np.testing.assert_array_equal(env["residual_displacement"].values, sol.q[-1])
    # the storeys yield (the drift passes fy / k) and an elastic-perfectly-plastic storey's force peaks at fy
    assert (env["drift"].values > FY / K_STOREY).all()
    epp = [s for s, spring in enumerate(structure.springs) if isinstance(spring.material, ElasticPlastic)]
    assert env["force"].values[epp] == pytest.approx(FY, rel=1e-15)
    assert env["force"].dims == ("spring",) and env["displacement"].dims == ("dof",)


def test_the_absolute_acceleration_is_the_relative_one_plus_the_grounds():
    # elastic (the springs never yield at this amplitude) so Solution.absolute_acceleration, which reads the
    # model's virgin materials, is a reference
    structure = frame()
    motion = record() * 0.02
    sol = raydamp.integrate(structure, np.zeros(3), np.zeros(3), load=motion,
                            envelope=["abs_acceleration", "acceleration", "drift"], **RUN)
    assert sol.envelope["drift"].values.max() < FY / K_STOREY
    absolute = np.abs(sol.absolute_acceleration())
    np.testing.assert_allclose(sol.envelope["abs_acceleration"].values, absolute.max(axis=0), rtol=1e-12)
    k = np.argmax(absolute, axis=0)
    np.testing.assert_array_equal(sol.envelope["abs_acceleration_time"].values, sol.t[k])
    # the ground's part is there: the relative peak differs
    assert not np.allclose(sol.envelope["acceleration"].values, sol.envelope["abs_acceleration"].values, rtol=1e-3)


def test_peaks_are_taken_at_every_step_not_only_at_saved_rows():
    structure = frame()
    every = raydamp.integrate(structure, np.zeros(3), np.zeros(3), load=record(), envelope=["drift"], **RUN)
    sparse = raydamp.integrate(structure, np.zeros(3), np.zeros(3), load=record(), envelope=["drift"],
                               save_every=97, **RUN)
    np.testing.assert_array_equal(sparse.envelope["drift"].values, every.envelope["drift"].values)
    np.testing.assert_array_equal(sparse.envelope["drift_time"].values, every.envelope["drift_time"].values)
    np.testing.assert_array_equal(sparse.q[-1], every.q[-1])  # the envelope changes nothing it observes
    saved = np.abs(drifts(structure, sparse.q)).max(axis=0)
    assert (saved < sparse.envelope["drift"].values).any()


def test_each_ensemble_member_has_its_single_runs_envelope_bit_for_bit():
    structure = frame()
    motions = [record(seed) for seed in (1, 2)]
    scales = [0.5, 1.5]
    listed = [m for m in motions for _ in scales]
    ens = raydamp.integrate_ensemble(structure, np.zeros(3), np.zeros(3), load=listed,
                                     parameters={"load.amplitude": scales * 2}, threads=2, save_every=1200,
                                     envelope=["drift", "abs_acceleration", "residual_drift"], **RUN)
    assert ens.envelope["drift"].dims == ("member", "spring")
    for i, (motion, scale) in enumerate(zip(listed, scales * 2)):
        single = raydamp.integrate(structure, np.zeros(3), np.zeros(3), load=motion * scale, save_every=1200,
                                   envelope=["drift", "abs_acceleration", "residual_drift"], **RUN)
        for name in ("drift", "drift_time", "abs_acceleration", "abs_acceleration_time", "residual_drift"):
            np.testing.assert_array_equal(ens.envelope[name].values[i], single.envelope[name].values)
        np.testing.assert_array_equal(ens.member(i).envelope["drift"].values, single.envelope["drift"].values)


def test_a_drift_past_its_collapse_limit_stops_the_run_and_says_which_spring():
    softening = frame([Bilinear(K_STOREY, FY, -0.1)] * STOREYS)
    limit = 0.08
    sol = raydamp.integrate(softening, np.zeros(3), np.zeros(3), load=record() * 4.0, envelope=["drift"],
                            collapse=limit, **RUN)
    assert sol.status == "collapsed", sol.message
    assert sol.steps < 1200 and sol.t[-1] == pytest.approx(sol.steps * RUN["h"], rel=1e-12)
    d = np.abs(drifts(softening, sol.q[-1]))
    s = sol.envelope.attrs["collapsed_spring"]
    assert d[s] > limit and f"springs[{s}]" in sol.message
    # the step before stayed within every limit
    assert (np.abs(drifts(softening, sol.q[-2])) <= limit).all()
    # without the limit the same run goes on, equal up to that step
    free = raydamp.integrate(softening, np.zeros(3), np.zeros(3), load=record() * 4.0, envelope=["drift"], **RUN)
    np.testing.assert_array_equal(free.q[:sol.t.size], sol.q)


@pytest.mark.parametrize(("model", "arguments", "named"), [
    ("frame", dict(envelope="drift"), r"envelope must be a list of names"),
    ("frame", dict(envelope=["drift", "peak"]), r"envelope\[1\]: unknown quantity 'peak'"),
    ("frame", dict(envelope=["drift", "drift"]), r"envelope\[1\]: 'drift' is listed twice"),
    ("linear", dict(envelope=["displacement", "drift"]), r"envelope\[1\]: 'drift' is a spring's"),
    ("linear", dict(collapse=0.1), r"collapse: a limit of a spring's drift, and this model has no springs"),
    ("frame", dict(collapse=[0.1, 0.2]), r"collapse: 2 values for 3 springs"),
    ("frame", dict(collapse=[0.1, -0.2, 0.1]), r"collapse\[1\] must be > 0"),
    ("frame", dict(envelope=["residual_drift"], save_dofs=[0]), r"envelope: a residual is read from the final"),
])
def test_bad_envelopes_are_refused_naming_the_argument(model, arguments, named):
    structure = frame() if model == "frame" else raydamp.LinearStructure(np.eye(3), np.eye(3) * 100.0)
    with pytest.raises(ValueError, match=named):
        raydamp.integrate(structure, np.zeros(3), np.zeros(3), h=0.01, n_steps=10, **arguments)
