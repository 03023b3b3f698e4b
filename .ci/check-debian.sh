#!/usr/bin/env bash
# check-debian: run the tests against Debian 13 "trixie" (apt's DOLFINx 0.9, Open MPI 5) in a
# debootstrap chroot built from docker/apt-packages.txt, the Dockerfile's package list.
#   bash .ci/check-debian.sh [pytest args]     (default: every test but those marked mpi and
#                                               the demos, then eight demos on 2 ranks; with
#                                               args: pytest -m "not mpi" ARGS)
# The root is cached in .cache/debian-trixie and rebuilt when the package list changes.
# No root, no chroot/mount rights or no route to Debian's registry: prints SKIPPED, exits 0.
set -euo pipefail

SCRIPT=$(realpath "${BASH_SOURCE[0]}")
cd "$(dirname "$SCRIPT")/.."
PROJECT=$(pwd -P)
ROOT=$PROJECT/.cache/debian-trixie
PKGS=$PROJECT/docker/apt-packages.txt
SUITE=trixie
STAMP_VERSION=2   # bump when the way the root is built changes
LOG=$PROJECT/.cache/debian-trixie.log

log() { echo "check-debian: $*"; }
skip() { log "SKIPPED ($*)"; exit 0; }

[[ $(id -u) -eq 0 ]] || skip "needs root for debootstrap/chroot"
chroot / true 2>/dev/null || skip "chroot is not permitted here"

# Re-run in a private mount namespace: the chroot's mounts never show on the host and vanish
# with the process even if it is killed. (The trap below unmounts them anyway.)
if [[ -z ${DGPLATE_CHECK_NS:-} ]] && unshare --mount --propagation private true 2>/dev/null; then
  DGPLATE_CHECK_NS=1 exec unshare --mount --propagation private bash "$SCRIPT" "$@"
fi

mkdir -p "$PROJECT/.cache"
ROOT=$(realpath -m "$ROOT")   # canonical, as /proc/PID/root shows it (.cache may be a symlink)
exec 9>"$PROJECT/.cache/debian-trixie.lock"
flock 9   # one run at a time per cache

# Run "$@" with output in $LOG; on failure skip if it was the network, else fail loudly.
net_run() {
  if "$@" >>"$LOG" 2>&1; then return 0; fi
  if grep -qiE 'temporary failure resolving|could not resolve|failed to fetch|couldn.t download|failed getting release|unable to connect|network is unreachable|no route to host|connection (refused|timed out)|could not connect' "$LOG"; then
    skip "Debian's registry unreachable: $* failed, see $LOG"
  fi
  tail -n 30 "$LOG"
  log "FAILED: $*"
  exit 1
}

# The Debian mirror this machine's apt uses (override: DGPLATE_DEBIAN_MIRROR).
detect_mirror() {
  if [[ -n ${DGPLATE_DEBIAN_MIRROR:-} ]]; then echo "$DGPLATE_DEBIAN_MIRROR"; return; fi
  cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list /etc/apt/sources.list.d/*.sources 2>/dev/null |
    grep -E '^[[:space:]]*(deb[[:space:]]|URIs:)' | grep -oE 'https?://[^[:space:]]+' |
    sed 's:/*$::' | grep -E '/debian$' | sed -n 1p || true
}

# Mounts inside the chroot, undone in reverse order on exit; processes left in it are ended.
MOUNTS=()
mount_in() { mount "$@" || return 1; MOUNTS+=("${@: -1}"); }
cleanup() {
  local p i
  for p in /proc/[0-9]*; do
    [[ $(readlink "$p/root" 2>/dev/null) == "$ROOT" ]] && kill "${p#/proc/}" 2>/dev/null
  done
  for ((i = ${#MOUNTS[@]} - 1; i >= 0; i--)); do
    umount "${MOUNTS[i]}" 2>/dev/null || umount -l "${MOUNTS[i]}" || true
  done
  MOUNTS=()
}
trap cleanup EXIT
mount_all() {
  mount_in -t proc proc "$ROOT/proc" || skip "cannot mount /proc in the chroot"
  mount_in -t sysfs sysfs "$ROOT/sys" 2>/dev/null || true   # optional; hwloc warns without it
  mount_in --bind /dev "$ROOT/dev" || skip "cannot bind-mount /dev into the chroot"
  mount --make-private "$ROOT/dev"                            # so nothing below reaches the host
  mount_in -t tmpfs -o mode=1777 shm "$ROOT/dev/shm"         # Open MPI shared memory
}

mapfile -t packages < <(sed -e 's/#.*//' -e 's/[[:space:]]//g' -e '/^$/d' "$PKGS")
want="$STAMP_VERSION $(sha256sum <"$PKGS" | cut -d' ' -f1)"

# 1. The trixie root with the package list, unless the cached one matches.
if [[ $(cat "$ROOT/.dgplate-ready" 2>/dev/null) != "$want" ]]; then
  : >"$LOG"
  if ! command -v debootstrap >/dev/null; then
    command -v apt-get >/dev/null || skip "debootstrap missing and no apt-get to install it"
    net_run apt-get update -q
    net_run env DEBIAN_FRONTEND=noninteractive apt-get install -y -q debootstrap
  fi
  mirror=$(detect_mirror)
  [[ -n $mirror ]] || skip "no Debian mirror found in /etc/apt/sources.list*"
  wget -q -T 20 -t 2 -O /dev/null "$mirror/dists/$SUITE/InRelease" ||
    skip "cannot reach $mirror/dists/$SUITE"
  log "building the $SUITE root in $ROOT from $mirror (log: $LOG)"
  # A run killed where no private mount namespace was available can leave its mounts (the
  # JIT cache's bind mount among them) in the root: undo them, and never delete through one.
  while read -r _ target _; do
    if [[ $target == "$ROOT"/* ]]; then umount -l "$target" 2>/dev/null || true; fi
  done </proc/mounts
  if grep -q " $ROOT/" /proc/mounts; then
    log "FAILED: mounts left under $ROOT; unmount them first"
    exit 1
  fi
  [[ ! -e $ROOT ]] || rm -rf --one-file-system "$ROOT"   # never crosses into a mount
  net_run debootstrap --variant=minbase "$SUITE" "$ROOT" "$mirror"
  printf 'deb %s %s main\ndeb %s %s-updates main\n' "$mirror" "$SUITE" "$mirror" "$SUITE" \
    >"$ROOT/etc/apt/sources.list"
  printf '#!/bin/sh\nexit 101\n' >"$ROOT/usr/sbin/policy-rc.d"   # start no services
  chmod +x "$ROOT/usr/sbin/policy-rc.d"
  echo force-unsafe-io >"$ROOT/etc/dpkg/dpkg.cfg.d/dgplate-unsafe-io"   # no fsync: a throwaway root
  mount_all
  log "installing ${#packages[@]} packages from docker/apt-packages.txt"
  net_run chroot "$ROOT" apt-get update -q
  net_run chroot "$ROOT" env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y -q --no-install-recommends "${packages[@]}"
  chroot "$ROOT" apt-get clean
  echo "$want" >"$ROOT/.dgplate-ready"
else
  log "reusing $ROOT"
  mount_all
fi

log "root ready after ${SECONDS}s"

# The chroot's FFCx JIT cache (/root/.cache) lives outside the clone, as ~/.cache/fenics does for
# the wheel: under DOLFINx 0.9 gcc compiling the forms is most of the tests' time (a problem file
# that runs in 1 s with its forms cached takes 150 s without), and a fresh clone builds a fresh
# root. One folder per set of installed package versions, so forms compiled by other versions
# are never loaded (override: DGPLATE_DEBIAN_JIT_CACHE; `rm -rf ~/.cache/dgplate` clears them).
# Without XDG_CACHE_HOME or a HOME folder (other than /) the cache stays inside the root.
packages_key=$(chroot "$ROOT" dpkg-query -W -f '${Package}=${Version}\n' | sha256sum | cut -c1-16)
cache_home=${XDG_CACHE_HOME:-}
if [[ -z $cache_home && -n ${HOME:-} && $HOME != / && -d $HOME ]]; then cache_home=$HOME/.cache; fi
host_cache=${DGPLATE_DEBIAN_JIT_CACHE:-${cache_home:+$cache_home/dgplate/debian-$SUITE-$packages_key}}
if [[ -n $host_cache ]] && mkdir -p "$host_cache" "$ROOT/root/.cache" 2>/dev/null &&
  mount_in --bind "$host_cache" "$ROOT/root/.cache" 2>/dev/null; then
  log "JIT cache: $host_cache ($(du -sh "$host_cache" 2>/dev/null | cut -f1))"
fi

# 2. The project (tracked + untracked non-ignored files, never .cache/.venv) into /project.
list_files() {
  git -C "$PROJECT" ls-files -co --exclude-standard -z 2>/dev/null ||
    (cd "$PROJECT" && find . -path ./.git -prune -o -type f -printf '%P\0')
}
rm -rf --one-file-system "$ROOT/project"
mkdir -p "$ROOT/project"
list_files | { grep -zvE '^\.(cache|venv|git)/' || true; } |
  tar -C "$PROJECT" --null --ignore-failed-read -T - -cf - | tar -C "$ROOT/project" -xf -

# 3. Run inside: clean environment, writable HOME, FFCx JIT cache in /root/.cache (see above).
CENV=(env -i PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin
  HOME=/root XDG_CACHE_HOME=/root/.cache LANG=C.UTF-8 PYTHONPATH=/project
  OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 OMPI_MCA_rmaps_base_oversubscribe=1
  PRTE_MCA_rmaps_default_mapping_policy=:oversubscribe "OMPI_MCA_btl=self,sm"
  PYVISTA_OFF_SCREEN=true MPLBACKEND=Agg
  DGPLATE_ALL_DEMOS_NP2=1)   # any demo may be picked for the 2-rank runs below
chroot "$ROOT" "${CENV[@]}" python3 -c '
from mpi4py import MPI
import dolfinx, basix, ufl, petsc4py
print("check-debian: dolfinx", dolfinx.__version__, "basix", basix.__version__, "ufl", ufl.__version__,
      "petsc4py", petsc4py.__version__, "|", MPI.Get_library_version().splitlines()[0].strip("\0 "))'
chroot "$ROOT" "${CENV[@]}" mpirun -n 2 python3 -c '
from mpi4py import MPI
import dolfinx.mesh
m = dolfinx.mesh.create_unit_square(MPI.COMM_WORLD, 4, 4)
n = MPI.COMM_WORLD.allreduce(m.topology.index_map(2).size_local)
assert n == 32, n
if MPI.COMM_WORLD.rank == 0:
    print("check-debian: mpirun -n 2 OK")'

if [[ ! -d $ROOT/project/tests ]]; then
  log "no tests/ yet: nothing more to run"
  exit 0
fi
# -noreset: Xvfb otherwise resets when its last client leaves and drops a client connecting
# meanwhile; VTK then aborts ("bad X server connection"). See dgplate.io.images.start_xvfb.
in_root() {
  chroot "$ROOT" "${CENV[@]}" /bin/sh -c \
    'cd /project && exec xvfb-run -a -s "-screen 0 1280x1024x24 -noreset" \
       python3 -m pytest -q "$@"' sh "$@"
}
rc=0
if (($# > 0)); then
  log "python3 -m pytest -q -m 'not mpi' $*"
  in_root -m "not mpi" "$@" || rc=$?
else
  # Every test but the demos on two workers; the tests that launch mpirun themselves; and a
  # demo of each driver and model family on 2 ranks (Open MPI), two at a time. `make test`
  # runs a set of demos on 2 ranks and the others serially with the wheel; here, on a cold JIT cache,
  # each demo pays for gcc compiling its forms (most of the time under DOLFINx 0.9), and all of
  # them would take CI past its 90 minutes.
  demos=(box_folding straight_fold fvk_buckling buckling_strip rod_circle self_avoiding_strip
    lce_strip obstacle_bnn)
  log "python3 -m pytest -q -n 2 --dist worksteal -m 'not mpi and not spawns_mpirun' (no demos)"
  in_root tests/ -n 2 --dist worksteal --durations=10 -m "not mpi and not spawns_mpirun" \
    -k "not test_demo_runs_and_checks_its_results" || rc=$?
  if ((rc == 0)); then
    log "python3 -m pytest -q -m 'spawns_mpirun and not mpi' (no demos)"
    in_root tests/ -m "spawns_mpirun and not mpi" \
      -k "not test_demo_runs_and_checks_its_results" || rc=$?
  fi
  if ((rc == 0)); then
    log "2-rank demos: ${demos[*]}"
    ids=()
    for demo in "${demos[@]}"; do
      ids+=("tests/demos/test_demos.py::test_demo_runs_and_checks_its_results[$demo-np2]")
    done
    in_root -n 2 --durations=10 "${ids[@]}" || rc=$?
  fi
fi
case $rc in
  0) log "PASSED in ${SECONDS}s" ;;
  5) log "no tests collected (${SECONDS}s)" ;;
  *) log "FAILED (pytest exit $rc)"; exit "$rc" ;;
esac
