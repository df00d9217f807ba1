"""Learned inverse dynamics, the files: dynamics data sets (HDF5, docs/data-format.md,
"Dynamics data"), trained model files, training and evaluation on them. JAX is imported
only by the training, when it runs (core.learning)."""
