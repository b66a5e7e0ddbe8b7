# mpi_common.sh - sourced by the tests/mpi scripts, in their scratch
# directory: how OpenMPI runs here, the tally, and the bit-for-bit
# comparison of two ensembles.
#
# A container without network or ptrace: shared memory between local ranks
# only, no single-copy (CMA) transfers, no ssh agent.
export OMPI_MCA_btl=self,vader OMPI_MCA_btl_vader_single_copy_mechanism=none OMPI_MCA_plm_rsh_agent=
MPIRUN=(timeout 300 mpirun --oversubscribe --allow-run-as-root)
checks=0
fails=0
fail() {
    echo "FAIL: $*" >&2
    fails=$((fails + 1))
}
DATA="/gyration/N /clusters/rg_diam /clusters/index /clusters/seed /clusters/particles /clusters/walkers
/clusters/jumps /clusters/rg_final_diam /clusters/r_ext_diam /clusters/D_f /clusters/D_f_err
/clusters/prefactor_diam /clusters/fit_n_lo /clusters/fit_n_hi /clusters/fit_points /clusters/positions
/statistics"
same_data() { # same_data A B WHAT: the datasets above are bit-identical (1: B has no ensemble.h5)
    local ds
    [ -f "$2/ensemble.h5" ] || { fail "$3: no $2/ensemble.h5"; return 1; }
    for ds in $DATA; do
        checks=$((checks + 1))
        # -c: h5diff exits 0 for datasets of other shapes ("not
        # comparable") and only says so with -c.
        [ -z "$(h5diff -q -c "$1/ensemble.h5" "$2/ensemble.h5" "$ds" "$ds" 2>&1)" ] || fail "$3: $ds differs"
    done
}
