#!/bin/bash
# test_mpi_env.sh - which launcher environments make `pdla ensemble` an MPI
# run (src/cli/ens_cmd.c, launcher_ranks; README "Across machines"): more
# than one rank in OMPI_COMM_WORLD_SIZE, in PMI_SIZE, or in SLURM_NTASKS
# under PMI/PMIx (PMI_RANK, PMIX_RANK or OMPI_COMM_WORLD_RANK set); a plain
# srun of a serial program sets SLURM_NTASKS too, and must run as usual.
# No launcher is needed: the variables are set by hand.
# Usage: test_mpi_env.sh PDLA nompi|mpi
#   nompi (a build with -Dmpi=disabled): each MPI environment is refused,
#     exit 2, one line from rank 0 only ("started as 2 MPI ranks, but this
#     pdla was built without MPI"), nothing written; the others run.
#   mpi: only the environments that are not MPI runs are tried (an MPI one
#     would call MPI_Init with no launcher): each runs as one process.
set -u
PDLA=${1:?usage: test_mpi_env.sh PDLA nompi|mpi}
MODE=${2:?usage: test_mpi_env.sh PDLA nompi|mpi}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-mpi-env.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1
checks=0 fails=0 n=0
fail() { echo "FAIL: $*"; fails=$((fails + 1)); }

# launch VAR=VALUE...: pdla ensemble in a clean environment (no launcher
# variable but those given); status in $rc, the run directory in $d.
launch() {
    n=$((n + 1)) checks=$((checks + 1))
    d=e$n
    env -u OMPI_COMM_WORLD_SIZE -u OMPI_COMM_WORLD_RANK -u PMI_SIZE -u PMI_RANK -u PMIX_RANK \
        -u SLURM_NTASKS -u SLURM_PROCID "$@" \
        timeout 120 "$PDLA" ensemble --clusters 2 --target 100 --out "$d" -q >out 2>err </dev/null
    rc=$?
}

# refused WHAT VAR=VALUE...: an MPI environment in a build without MPI.
refused() {
    local what=$1 rank0=1
    shift
    launch "$@"
    case " $* " in *" PMI_RANK=1 "* | *" OMPI_COMM_WORLD_RANK=1 "*) rank0=0 ;; esac
    [ "$rc" -eq 2 ] || fail "$what: exit status $rc, want 2 (refused): $(cat err)"
    [ -e "$d" ] && fail "$what: $d was written"
    if [ $rank0 -eq 1 ]; then
        [ "$(wc -l <err)" -eq 1 ] && grep -q "^pdla ensemble: started as 2 MPI ranks, but this pdla was built without MPI" err ||
            fail "$what: want one line naming 2 ranks and the build without MPI: $(cat err)"
    else
        [ -s err ] && fail "$what: rank 1 printed (only rank 0 should): $(cat err)"
    fi
}

# runs WHAT VAR=VALUE...: not an MPI run; grows the ensemble as usual.
runs() {
    local what=$1
    shift
    launch "$@"
    [ "$rc" -eq 0 ] && [ -f "$d/ensemble.h5" ] && [ ! -s err ] ||
        fail "$what: exit status $rc, ensemble.h5 $([ -f "$d/ensemble.h5" ] && echo written || echo missing), want a plain run: $(cat err)"
}

if [ "$MODE" = nompi ]; then
    refused "PMI_SIZE=2 (rank 0)" PMI_SIZE=2 PMI_RANK=0
    refused "PMI_SIZE=2 (rank 1)" PMI_SIZE=2 PMI_RANK=1
    refused "OMPI_COMM_WORLD_SIZE=2 (rank 0)" OMPI_COMM_WORLD_SIZE=2 OMPI_COMM_WORLD_RANK=0
    refused "SLURM_NTASKS=2 under PMIx" SLURM_NTASKS=2 SLURM_PROCID=0 PMIX_RANK=0
    refused "SLURM_NTASKS=2 under PMI" SLURM_NTASKS=2 SLURM_PROCID=0 PMI_RANK=0
    runs "PMI_SIZE=1" PMI_SIZE=1 PMI_RANK=0
fi
runs "SLURM_NTASKS=2 without PMI (a plain srun)" SLURM_NTASKS=2 SLURM_PROCID=0
runs "SLURM_NTASKS=2, SLURM_PROCID=1 without PMI" SLURM_NTASKS=2 SLURM_PROCID=1
runs "OMPI_COMM_WORLD_SIZE=1" OMPI_COMM_WORLD_SIZE=1 OMPI_COMM_WORLD_RANK=0
runs "no launcher"
echo "$checks checks, $fails failed ($MODE build)"
[ "$fails" -eq 0 ]
