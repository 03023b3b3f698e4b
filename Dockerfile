# dgplate on Debian 13 "trixie": DOLFINx 0.9 (PETSc real, Open MPI 5) from apt packages only.
# The same package list is checked without Docker by `make check-debian` (.ci/check-debian.sh).
#   docker build -t dgplate .
#   docker run --rm dgplate                          # main demo on 2 ranks (docker/run-demo.sh)
#   docker run --rm dgplate python3 -m pytest -q -m "not mpi" tests/
FROM debian:trixie

# Open MPI refuses to run as root without the ALLOW_RUN_AS_ROOT pair. Oversubscription (more ranks
# than cores) is PRTE_MCA_rmaps_default_mapping_policy in Open MPI 5 (trixie); the OMPI_MCA_ name is
# Open MPI 4's. One container = one node, so use shared memory only (btl self,sm).
# pyvista draws off-screen through Xvfb (Debian's VTK has no OSMesa/EGL build): see run-demo.sh.
ENV DEBIAN_FRONTEND=noninteractive \
    LANG=C.UTF-8 \
    OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_rmaps_base_oversubscribe=1 \
    PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe \
    OMPI_MCA_btl=self,sm \
    PYVISTA_OFF_SCREEN=true \
    MPLBACKEND=Agg

# apt packages come only from docker/apt-packages.txt (comments stripped)
COPY docker/apt-packages.txt /tmp/apt-packages.txt
RUN apt-get update \
 && apt-get install -y --no-install-recommends $(sed -e 's/#.*//' /tmp/apt-packages.txt) \
 && rm -rf /var/lib/apt/lists/* /tmp/apt-packages.txt

WORKDIR /dgplate
COPY . /dgplate
# System install with --no-deps: all dependencies are apt packages, pip touches nothing apt owns
# (it only adds dgplate under /usr/local/lib/python3.13/dist-packages), and python3/mpirun need no
# PATH tricks. A venv with --system-site-packages would work too but buys nothing in a
# single-purpose image. --no-build-isolation uses apt's build backend (python3-setuptools), not PyPI.
RUN pip install --no-deps --no-build-isolation --break-system-packages . \
 && python3 -c "from mpi4py import MPI; import dolfinx, dgplate; print('dolfinx', dolfinx.__version__)"

CMD ["docker/run-demo.sh"]
