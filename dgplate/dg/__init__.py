"""The discontinuous Galerkin core: forms, energies and the geometry of a deformed plate."""
