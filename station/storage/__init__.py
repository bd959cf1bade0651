"""Records and runs on disk: CSV rate records, the HDF5 run file, its recovery (depends only on
model)."""
