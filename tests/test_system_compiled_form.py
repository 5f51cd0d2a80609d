"""A System's compiled functions as bytes (System.compiled_form, load_compiled): compiled in one process,
loaded in another with no compile, and the same machine code, so the same bits (issue 27: the service's
check processes compile, the server only loads)."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

import raydamp
from raydamp.systems.system import NotCompiled, System, compiled_elsewhere, load_compiled
from raydamp.systems.system import compile as compile_module
from raydamp.systems.system.compile import CompiledSystemFunctions

PYTHON_DIR = Path(raydamp.__file__).resolve().parents[1]


def spring_pair(k: float = 0.3) -> dict:
    """Every compiled function at once: one dashpot on a distance (its projection and the fused 3s body)
    and a momentum map."""
    return {"coordinates": ["x", "y"], "potential": f"x^2/2 + y^2/2 + {k!r}*(x - y)^4 + sin(x)*y",
            "damping": {"dampers": [{"on": "sqrt(x^2 + y^2)"}]}, "eps": 0.2,
            "momenta": {"L": "x*p_y - y*p_x"}}


def quartic(n: int) -> dict:
    return {"coordinates": n, "potential": "(" + "+".join(f"q{i}^2" for i in range(n)) + ")^2"}


def _inputs(compiled: CompiledSystemFunctions, n: int) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(7)
    widths = {"potential": n, "gradient": n, "hessian_product": 2 * n, "damper_gradients": n, "momenta": 2 * n,
              "damper_projection": 2 * n, "damp_then_3s_body": 2 * n + 4}
    return {name: rng.standard_normal(width) for name, width in widths.items()
            if getattr(compiled, name) is not None}


def test_every_function_loads_bit_identical_with_its_own_addresses():
    system = System.from_dict(spring_pair())
    compiled = system._compiled
    assert compiled.damper_projection is not None and compiled.damp_then_3s_body is not None
    key, data = system.compiled_form()
    loaded = CompiledSystemFunctions.from_bytes(data)
    assert loaded.damper_norm == compiled.damper_norm
    assert len(loaded.addresses) == len(compiled.addresses) == 14
    for mine, theirs in zip(compiled.addresses, loaded.addresses):
        assert (mine == 0) == (theirs == 0)
    assert loaded.addresses != compiled.addresses  # derived again, for the loaded copy
    for name, x in _inputs(compiled, 2).items():
        expected = np.asarray(getattr(compiled, name)(x))
        assert np.asarray(getattr(loaded, name)(x)).tobytes() == expected.tobytes(), name


_OTHER_PROCESS = textwrap.dedent("""
    import pickle, sys
    import numpy as np
    import raydamp
    from raydamp.systems.system import System, compiled_elsewhere, load_compiled
    from raydamp.systems.system import compile as compile_module

    system, key, data, q0, p0 = pickle.load(sys.stdin.buffer)
    def refuse(spec):
        raise AssertionError("compiled in the process that was to load")
    compile_module._compile = refuse
    load_compiled(key, data)
    with compiled_elsewhere():
        model = System.from_dict(system)
    solution = raydamp.integrate(model, q0, p0, method="3s", h=0.01, n_steps=500)
    pickle.dump({name: np.asarray(getattr(solution, name)) for name in ("t", "q", "p", "energy", "momentum", "work")},
                sys.stdout.buffer)
""")


@pytest.mark.parametrize("system", [spring_pair(), quartic(12)], ids=["dashpot+momenta", "quartic12"])
def test_a_run_in_another_process_from_the_bytes_equals_the_run_here_bit_for_bit(system):
    model = System.from_dict(system)
    n = model.dim
    q0, p0 = np.linspace(0.3, -0.2, n), np.linspace(-0.1, 0.1, n)
    here = raydamp.integrate(model, q0, p0, method="3s", h=0.01, n_steps=500)
    key, data = model.compiled_form()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(PYTHON_DIR), os.environ.get("PYTHONPATH")]))}
    done = subprocess.run([sys.executable, "-c", _OTHER_PROCESS], input=pickle.dumps((system, key, data, q0, p0)),
                          capture_output=True, env=env, timeout=120)
    assert done.returncode == 0, done.stderr.decode()[-3000:]
    there = pickle.loads(done.stdout)
    for name, values in there.items():
        assert values.tobytes() == np.asarray(getattr(here, name)).tobytes(), name


def test_within_compiled_elsewhere_an_unloaded_system_is_not_compiled():
    system = spring_pair(k=0.123456789)  # a key no other test compiles
    with compiled_elsewhere(), pytest.raises(NotCompiled):
        System.from_dict(system)
    with pytest.raises(NotCompiled):  # nor through the job door (raydamp.jobs caches Systems by their JSON)
        with compiled_elsewhere():
            raydamp.jobs.build_job(raydamp.jobs.parse_job(
                {"system": system, "method": "3s", "h": 0.01, "n_steps": 2, "initial_state": {"rest": True}}))
    compiled = System.from_dict(system)  # outside: compiled (and cached)
    with compiled_elsewhere():
        assert System.from_dict(system)._compiled is compiled._compiled


def test_loaded_functions_serve_a_system_built_later(monkeypatch):
    key, data = System.from_dict(quartic(5)).compiled_form()
    monkeypatch.setattr(compile_module, "_cache", type(compile_module._cache)())  # as a fresh process
    monkeypatch.setattr(compile_module, "_compile", lambda spec: pytest.fail("compiled although loaded"))
    load_compiled(key, data)
    with compiled_elsewhere():
        model = System.from_dict({**quartic(5), "name": "another name"})  # the name is not compiled in
    assert np.isfinite(raydamp.integrate(model, [0.1] * 5, [0.0] * 5, method="3s", h=0.01, n_steps=10).q).all()


def test_the_compiled_functions_depend_on_the_expressions_not_on_eps_or_coefficients():
    system = System.from_dict(spring_pair())
    same = [system.replace(eps=0.7), system.replace(damping={"dampers": [{"on": "sqrt(x^2 + y^2)", "c": 3.0}]}),
            system.replace(name="renamed")]
    assert all(other._compiled is system._compiled for other in same)
    different = [system.replace(potential="x^2/2 + y^2/2"), system.replace(mass=[1.0, 2.0]),
                 system.replace(coordinates=["y", "x"])]
    assert all(other._compiled is not system._compiled for other in different)


class _Trap:
    def __reduce__(self):
        return (os.system, ("true",))


@pytest.mark.parametrize("data", [
    pickle.dumps(("raydamp.compiled_system.1", [_Trap()] * 7, None)),
    pickle.dumps(os.getcwd),
    pickle.dumps(np.arange(3)),  # numpy's array reconstructor: not SymEngine's loader either
], ids=["os.system", "a function", "an array"])
def test_bytes_naming_anything_but_symengines_loader_are_refused(data):
    with pytest.raises(pickle.UnpicklingError, match="not loadable here"):
        CompiledSystemFunctions.from_bytes(data)


def test_bytes_of_another_form_are_refused():
    with pytest.raises(ValueError, match="not what CompiledSystemFunctions.to_bytes writes"):
        CompiledSystemFunctions.from_bytes(pickle.dumps(("raydamp.compiled_system.0", [], None)))


def test_a_function_system_has_no_compiled_form():
    system = System.from_functions(1, potential=lambda q: float(q[0] ** 2), gradient=lambda q: 2 * q)
    with pytest.raises(ValueError, match="no compiled functions"):
        system.compiled_form()
