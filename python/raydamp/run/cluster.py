"""The Dask LocalCluster that raydamp starts for a sweep when it is given no client: every server it opens
(the scheduler, the workers, their HTTP servers) listens on this machine's loopback address only."""

from __future__ import annotations

__all__ = ["local_cluster"]

LOOPBACK = "127.0.0.1"


def local_cluster(workers: int, threads: int = 1, processes: bool = True):
    """A LocalCluster of ``workers`` workers of ``threads`` threads (in processes, or threads of this one).

    Dask's defaults open the scheduler's HTTP server on every interface at port 8787, even with
    ``dashboard_address=None`` (which only leaves the dashboard's pages out): a service bound to
    127.0.0.1 then answered Dask's /info and /json pages on the machine's other addresses (an audit found
    it). Here they listen on 127.0.0.1, at ports the system chooses (no clash on 8787 either)."""
    from dask.distributed import LocalCluster

    # Worker processes reach the scheduler over TCP, bound to loopback; threads of this process, in-process.
    where = {"host": LOOPBACK} if processes else {}
    return LocalCluster(n_workers=workers, threads_per_worker=threads, processes=processes, **where,
                        dashboard_address=None, scheduler_kwargs={"dashboard_address": f"{LOOPBACK}:0"},
                        worker_dashboard_address=f"{LOOPBACK}:0")
