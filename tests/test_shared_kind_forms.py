"""The JSON forms of the shared kinds (Chain, Kepler, Planets) are checked key by key through one
SharedModel._from_form: each error names its key."""

from __future__ import annotations

import pytest

import raydamp


@pytest.mark.parametrize("cls,kind,label,required", [
    (raydamp.Chain, "chain", "chain", r"^n: missing \(the number of sites\)$"),
    (raydamp.Kepler, "kepler", "Kepler system", None),
    (raydamp.Planets, "planets", "Planets system", r"^masses: required \(the planets' masses\)$"),
])
def test_each_error_names_its_key(cls, kind, label, required):
    with pytest.raises(ValueError, match=rf'^system: a {label} must be an object with kind "{kind}"$'):
        cls.from_dict([kind])
    with pytest.raises(ValueError, match=rf"^colour: unknown key of a {label} \(known: kind, "):
        cls.from_dict({"kind": kind, "colour": 1})
    with pytest.raises(ValueError, match=rf'^kind: expected "{kind}", got '):
        cls.from_dict({"kind": "lattice"})
    if required is not None:
        with pytest.raises(ValueError, match=required):
            cls.from_dict({"kind": kind})


def test_a_form_builds_the_same_kind_back():
    for system in (raydamp.Kepler(mu=2.0, eps=1e-3), raydamp.Planets([1e-3, 2e-3], eps=[1e-4, 0.0])):
        assert type(system).from_dict(system.to_dict()).to_dict() == system.to_dict()
