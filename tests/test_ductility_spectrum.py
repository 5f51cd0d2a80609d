"""raydamp.ductility_spectrum against an event-driven exact solution that is not raydamp (tests/ductility_reference.py).

At the fy each period's search found, the exact solution's ductility equals the target to 5e-5 relative
(measured 2.5e-5 at the default 64 steps per period; the search's own tolerance is 1e-6); at larger fy (from the
one found up to 1.5 f0) it stays below the target, as "the largest fy" requires.
"""

from __future__ import annotations

import numpy as np
import pytest
from ductility_reference import peak_ductility

import raydamp
from raydamp.materials import Bilinear

DT = 0.01
T_REC = np.arange(301) * DT
A_G = (3.0 * np.sin(2 * np.pi * T_REC / 0.5) * np.exp(-(((T_REC - 1.2) / 0.8) ** 2))
       + 2.0 * np.sin(2 * np.pi * T_REC / 1.1 + 0.4) * np.exp(-(((T_REC - 1.8) / 0.7) ** 2)))
PERIODS = [0.3, 0.7, 1.5]


@pytest.fixture(scope="module")
def spectrum():
    return raydamp.ductility_spectrum((T_REC, A_G), PERIODS, [2.0, 4.0], damping=0.05)


def test_the_exact_solution_at_the_fy_found_has_the_target_ductility(spectrum):
    for j, mu in enumerate((2.0, 4.0)):
        for i, period in enumerate(PERIODS):
            fy = float(spectrum.Ay[j, i])  # per unit mass
            exact = peak_ductility(T_REC, A_G, period, 0.05, fy)
            assert abs(exact / mu - 1.0) <= 5e-5, (mu, period, exact)
            assert abs(float(spectrum.ductility_achieved[j, i]) / mu - 1.0) <= 1e-5


def test_larger_strengths_stay_below_the_target(spectrum):
    for i, period in enumerate(PERIODS):
        ratio, f0 = float(spectrum.fy_ratio[1, i]), float(spectrum.Ay[1, i] / spectrum.fy_ratio[1, i])
        for above in (ratio * 1.02, 0.5 * (ratio + 1.5)):
            assert peak_ductility(T_REC, A_G, period, 0.05, above * f0) < 4.0, (period, above)


def test_the_dataset_is_consistent(spectrum):
    assert spectrum.fy_ratio.dims == ("ductility", "period")
    assert list(spectrum.period.values) == PERIODS and list(spectrum.ductility.values) == [2.0, 4.0]
    omega = 2 * np.pi / np.array(PERIODS)
    np.testing.assert_allclose(spectrum.Ay, omega ** 2 * spectrum.Dy, rtol=1e-14)
    np.testing.assert_allclose(spectrum.SD, spectrum.ductility_achieved * spectrum.Dy, rtol=1e-14)
    np.testing.assert_allclose(spectrum.Dy, spectrum.fy_ratio * spectrum.elastic_SD, rtol=1e-14)
    elastic = raydamp.response_spectrum((T_REC, A_G), PERIODS, damping=0.05)
    np.testing.assert_array_equal(spectrum.elastic_SD, elastic.SD)
    # a larger ductility needs a smaller strength, at each of these periods
    assert np.all(spectrum.fy_ratio[1] < spectrum.fy_ratio[0])


def test_a_bilinear_material_keeps_its_b_and_reaches_the_target():
    ds = raydamp.ductility_spectrum((T_REC, A_G), [0.5], 3.0, material=Bilinear(1.0, 1.0, 0.05))
    assert abs(float(ds.ductility_achieved[0, 0]) / 3.0 - 1.0) <= 1e-5
    assert "b=0.05" in ds.attrs["material"]


@pytest.mark.parametrize("arguments,name", [
    ({"ductility": 0.5}, "ductility"), ({"ductility": [2.0, float("nan")]}, "ductility"),
    ({"periods": [0.5, -1.0]}, "periods"), ({"damping": 1.0}, "damping"), ({"material": "epp"}, "material"),
    ({"steps_per_period": 4}, "steps_per_period"), ({"tolerance": 0.5}, "tolerance"),
    ({"record": (T_REC, 0.0 * A_G)}, "record")])
def test_bad_input_names_its_argument_first(arguments, name):
    call = {"record": (T_REC, A_G), "periods": [0.5], "ductility": 2.0, **arguments}
    with pytest.raises(ValueError, match=f"^{name}"):
        raydamp.ductility_spectrum(call.pop("record"), call.pop("periods"), call.pop("ductility"), **call)
