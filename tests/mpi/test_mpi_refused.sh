#!/bin/bash
# test_mpi_refused.sh - a pdla built without MPI (meson -Dmpi=disabled),
# started by mpirun with 2 ranks: `pdla ensemble` refuses (exit 2, one line
# from rank 0 naming the missing MPI build) and writes nothing, instead of
# growing the whole ensemble once per rank. A single rank runs as usual.
# Usage: test_mpi_refused.sh PDLA. Exit 77 (skipped) without mpirun.
set -u
PDLA=${1:?usage: test_mpi_refused.sh PDLA}
case $PDLA in /*) ;; *) PDLA=$(pwd)/$PDLA ;; esac
command -v mpirun >/dev/null || { echo "mpirun not installed (apt-get install openmpi-bin): skipped"; exit 77; }
tmp=$(mktemp -d "${TMPDIR:-/tmp}/pdla-mpi-refused.XXXXXX") || exit 1
trap 'rm -rf "$tmp"' EXIT
cd "$tmp" || exit 1
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_plm_rsh_agent=
fails=0
timeout 120 mpirun --oversubscribe --allow-run-as-root -n 2 "$PDLA" ensemble --clusters 2 --target 100 --out e \
    >out 2>err </dev/null
rc=$?
[ "$rc" -eq 2 ] || { echo "FAIL: exit status $rc, want 2: $(cat err)"; fails=1; }
[ "$(grep -c '^pdla ensemble:' err)" -eq 1 ] || { echo "FAIL: want one line: $(cat err)"; fails=1; }
grep -q "built without MPI" err || { echo "FAIL: message: $(cat err)"; fails=1; }
[ -e e ] && { echo "FAIL: e was written"; fails=1; }
timeout 120 mpirun --oversubscribe --allow-run-as-root -n 1 "$PDLA" ensemble --clusters 2 --target 100 --out one -q \
    >out 2>err </dev/null
rc=$?
[ "$rc" -eq 0 ] && [ -f one/ensemble.h5 ] || { echo "FAIL: mpirun -n 1: status $rc: $(cat err)"; fails=1; }
"$PDLA" ensemble --help 2>&1 | grep -q "This build has no MPI" || { echo "FAIL: ensemble --help does not say the build has no MPI"; fails=1; }
[ "$fails" -eq 0 ] && echo "refused under mpirun -n 2, ran under -n 1"
exit "$fails"
