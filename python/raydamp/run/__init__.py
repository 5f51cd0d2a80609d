"""Running a system: integrate.py (one run), ensemble.py (many runs of one system in one
compiled call), sweep.py (a grid of runs in chunks over Dask), job.py (the job JSON turned into
integrate's arguments)."""
