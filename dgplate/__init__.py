"""dgplate: large bending deformations of thin plates by interior-penalty dG in DOLFINx."""

from mpi4py import MPI  # noqa: F401  (MPI must be initialised before dolfinx is imported)

from dgplate.errors import DgplateError, InputError, SolverError, UnsupportedVersionError

__version__ = "0.1.0"

__all__ = ["DgplateError", "InputError", "SolverError", "UnsupportedVersionError", "__version__"]
