"""What a run gives back: solution.py (Solution), ensemble_solution.py (EnsembleSolution),
provenance.py (the job JSON a result records), plotting.py (``sol.plot``), io/ (results as
NetCDF, NPZ, CSV and Zarr files, and ``load``)."""
