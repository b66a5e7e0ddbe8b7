#!/usr/bin/env bash
# test_check_returns.sh SOURCE_DIR: no HDF5, pthread or MPI return value of
# src/ is thrown away unless scripts/check-returns.allow lists it with a
# reason, and no stale entry in that list (scripts/check-returns). First it
# checks that the check can fail: on a scratch tree, each kind of discarded
# call must be reported at its line (a bare statement, one split over lines
# after an `if`, a cast to void (after an `if` head or `else` too), a comma
# at statement level, after a label),
# the discarded status of a wrapper of an HDF5 close too, a call that can fail
# at run time inside PDLA_MUST must be refused, a stale
# or reasonless allow entry must be reported, and calls whose value is used
# (or that only a comment or a string names) must not be.
set -u
src=$1
cr="$src/scripts/check-returns"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail=0
mkdir -p "$tmp/src/m" "$tmp/scripts"
cat >"$tmp/src/m/a.c" <<'C'
int bare(hid_t f)
{
    H5Fclose(f);
    return 0;
}
int split(pthread_mutex_t *mu, int x)
{
    if (x)
        pthread_mutex_lock(
            mu);
    return 0;
}
void voided(hid_t g) { (void)H5Gclose(g); }
void comma(hid_t a, hid_t b)
{
    H5Sclose(a), H5Dclose(b);
}
void labelled(void)
{
done:
    MPI_Finalize();
}
void must(pthread_t *t)
{
    PDLA_MUST(pthread_create(t, NULL, NULL, NULL));
}
int used(hid_t f, pthread_mutex_t *mu, int c)
{
    /* H5Fclose(f); in a comment */
    const char *s = "H5Fclose(f);";
    if (H5Fclose(f) < 0) return -1;
    int rc = pthread_mutex_init(mu, NULL);
    rc = c ? H5Gclose(f) : H5Oclose(f);
    PDLA_MUST(pthread_mutex_unlock(mu));
    MPI_TRY(MPI_Barrier(MPI_COMM_WORLD), "barrier");
    if (rc || (H5Tclose(f) < 0 &&
               H5Pclose(f) < 0))
        return -1;
    return MPI_Send(s, 1, MPI_BYTE, 0, 0, MPI_COMM_WORLD);
}
void wrapper(pdla_h5_dset *d)
{
    pdla_h5_dset_close(d);
}
void guarded(hid_t f, int x)
{
    if (x) (void)H5Fclose(f);
    else (void)H5Gclose(f);
}
C
printf 'src/m/a.c gone H5Fclose a call that is no longer there\nsrc/m/a.c used\n' >"$tmp/allow"
out=$(python3 "$cr" --allow "$tmp/allow" "$tmp/src")
rc=$?
for want in "a.c:3: H5Fclose(...) in bare: its return value is discarded" \
            "a.c:9: pthread_mutex_lock(...) in split: its return value is discarded" \
            "a.c:13: H5Gclose(...) in voided: its return value is cast to void" \
            "a.c:16: H5Sclose(...) in comma" "a.c:16: H5Dclose(...) in comma" \
            "a.c:21: MPI_Finalize(...) in labelled" \
            "a.c:25: pthread_create(...) in must: can fail at run time, so not through PDLA_MUST" \
            "a.c:43: pdla_h5_dset_close(...) in wrapper: its return value is discarded" \
            "a.c:47: H5Fclose(...) in guarded: its return value is cast to void" \
            "a.c:48: H5Gclose(...) in guarded: its return value is cast to void" \
            "allow:1: src/m/a.c gone H5Fclose matches no discarded call" \
            "allow:2: want FILE FUNCTION CALL REASON"; do
    grep -qF -- "$want" <<<"$out" || { echo "FAIL: the check missed: $want"; fail=1; }
done
if [ $rc -eq 0 ]; then echo "FAIL: the check passed a tree with discarded returns"; fail=1; fi
n=$(grep -c "^check-returns: .*a.c:" <<<"$out")
if [ "$n" -ne 10 ]; then echo "FAIL: want 10 reports of a.c, got $n:"; echo "$out"; fail=1; fi
# Listed with a reason, each is accepted; `(void)NAME` covers only the cast.
cat >"$tmp/allow" <<'A'
src/m/a.c bare H5Fclose reason
src/m/a.c split pthread_mutex_lock reason
src/m/a.c voided (void)H5Gclose reason
src/m/a.c comma H5Sclose reason
src/m/a.c comma H5Dclose reason
src/m/a.c labelled MPI_Finalize reason
src/m/a.c wrapper pdla_h5_dset_close reason
src/m/a.c guarded (void)H5Fclose reason
src/m/a.c guarded (void)H5Gclose reason
A
out=$(python3 "$cr" --allow "$tmp/allow" "$tmp/src")
if ! grep -q "in must: can fail at run time" <<<"$out" || [ "$(grep -c '^check-returns: .*a.c:' <<<"$out")" -ne 1 ]; then
    echo "FAIL: listed calls were refused, or PDLA_MUST(pthread_create) accepted: $out"; fail=1
fi
sed -i '/PDLA_MUST(pthread_create/d' "$tmp/src/m/a.c"
echo 'void voided2(hid_t g) { H5Gclose(g); }' >>"$tmp/src/m/a.c"
sed -i 's/^src\/m\/a.c voided /src\/m\/a.c voided2 /' "$tmp/allow"
out=$(python3 "$cr" --allow "$tmp/allow" "$tmp/src")
if ! grep -q "in voided2: its return value is discarded" <<<"$out"; then
    echo "FAIL: a (void)H5Gclose entry covered a bare H5Gclose: $out"; fail=1
fi
# The real tree.
python3 "$cr" --allow "$src/scripts/check-returns.allow" "$src/src" || fail=1
exit $fail
