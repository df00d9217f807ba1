"""The console's tests. A regular package, not a namespace: pyemgpipeline (the EMG
envelope's cross-check) installs a top-level package named `tests` into site-packages, which
would otherwise win the name in the processes some tests spawn (tests/device/test_ring.py)."""
