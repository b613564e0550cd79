"""Imported by pytest before any test module: swarmnav first, so that its numerics settings
(docs/determinism.md) are in force before a test module's own imports load NumPy's or SciPy's
libraries (a test module importing ``scipy.integrate`` first changed later runs' kernels)."""

import swarmnav  # noqa: F401
