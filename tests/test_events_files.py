"""Events in result files and sweeps (issue 41): a Solution's events table is written beside its trajectory
(.nc, .npz) and read back; a sweep keeps each member's crossings, equal to its single run's."""

from __future__ import annotations

import numpy as np
import pytest

import raydamp
from raydamp.models import DampedPendulum

xr = pytest.importorskip("xarray")

LEVELS = [raydamp.Event("q[0]", name="vertical"), raydamp.Event("p[0] + 0.5", direction=-1, name="fast")]


@pytest.mark.parametrize("suffix", [".nc", ".npz"])
def test_the_events_table_is_saved_beside_the_trajectory_and_read_back(tmp_path, suffix):
    sol = raydamp.integrate(DampedPendulum(eps=0.05), [2.0], [0.0], method="3s", h=0.01, t_end=20.0, save_every=50,
                            events=LEVELS)
    assert len(sol.events) > 5
    path = tmp_path / f"run{suffix}"
    sol.save(path)
    back = raydamp.load(path)
    assert back.events.names == ("vertical", "fast")
    np.testing.assert_array_equal(back.events.t, sol.events.t)
    np.testing.assert_array_equal(back.events.event, sol.events.event)
    np.testing.assert_array_equal(back.events.direction, sol.events.direction)
    np.testing.assert_array_equal(back.events.q, sol.events.q)
    np.testing.assert_array_equal(back.events.p, sol.events.p)
    np.testing.assert_array_equal(back.q, sol.q)


def test_a_run_without_crossings_keeps_its_event_names():
    sol = raydamp.integrate(DampedPendulum(), [0.5], [0.0], h=0.01, t_end=1.0, events=[raydamp.Event("q[0] - 3")])
    ds = sol.to_xarray()
    assert "event_t" not in ds and ds.attrs["event_names"] == '["event0"]'


def test_a_sweep_keeps_each_members_crossings_as_its_single_run(tmp_path):
    distributed = pytest.importorskip("dask.distributed")
    spec = {"model": "damped_pendulum", "parameters": {"eps": 0.05}, "q0": [1.0], "p0": [0.0], "method": "3s",
            "h": 0.02, "t_end": 12.0, "save_every": 100,
            "events": [{"g": "q[0]", "name": "vertical"},
                       {"g": "p[0]", "direction": 1, "terminal": True, "name": "turn"}]}
    with distributed.Client(processes=False, n_workers=1, threads_per_worker=1, dashboard_address=":0") as client:
        ds = raydamp.sweep(spec, grid={"q0[0]": [0.5, 1.5, 2.5], "eps": [0.0, 0.2]}, client=client, chunk_size=4)
    assert ds.attrs["event_names"] == '["vertical", "turn"]'
    assert ds["event_t"].dims == ("member", "crossing")
    for k in range(ds.sizes["member"]):
        single = raydamp.integrate(DampedPendulum(eps=float(ds["eps"][k])), [float(ds["q0"][k, 0])], [0.0],
                                   method="3s", h=0.02, t_end=12.0, save_every=100, events=spec["events"])
        count = int(ds["event_count"][k])
        assert count == len(single.events) >= 2  # the vertical, then the turn that ends the member
        np.testing.assert_array_equal(ds["event_t"].values[k, :count], single.events.t)
        np.testing.assert_array_equal(ds["event_index"].values[k, :count], single.events.event)
        np.testing.assert_array_equal(ds["event_direction"].values[k, :count], single.events.direction)
        assert np.isnan(ds["event_t"].values[k, count:]).all()
        assert float(ds["t_final"][k]) == single.t[-1]
        assert ds["status"].attrs["flag_meanings"].split()[int(ds["status"][k])] == single.status == "event"
