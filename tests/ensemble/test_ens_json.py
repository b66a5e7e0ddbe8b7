#!/usr/bin/python3
"""test_ens_json.py PDLA - `pdla analyze ENSEMBLE --json` is JSON.

An ensemble of 4 clusters of 2000 particles with 2 R_g samples a decade has
local slopes that are NaN (windows with too few points): the output must
parse as strict JSON (no NaN, Infinity or nan, which JSON does not have),
with null where /statistics holds NaN and the file's numbers elsewhere (to
the 6 digits printed).

One cluster: no bootstrap interval (its resamples are all that cluster, so
the interval had zero width): D_f_lo, D_f_hi, D_f_boot_sd, the slope bands
and the correction fit's intervals NaN in ensemble.h5 (as se_rg and
D_f_cluster_sd), null in --json, "n/a" in the text; two clusters give real
intervals.
Prints one line per failure and "N checks, N failed"; exit 1 on a failure.
"""
import json
import math
import os
import subprocess
import sys
import tempfile

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally  # noqa: E402

TALLY = Tally()
check = TALLY.check


def run(args):
    p = subprocess.run(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, stdin=subprocess.DEVNULL)
    return p.returncode, p.stdout.decode(errors="replace"), p.stderr.decode(errors="replace")


def strict_json(text):
    """json.loads that refuses NaN and Infinity (Python takes them by default)."""
    def refuse(c):
        raise ValueError("not JSON: " + c)
    return json.loads(text, parse_constant=refuse)


def same(got, want, digits):
    """got (JSON: a number or None) against want (the file: NaN is None)."""
    if math.isnan(want):
        return got is None
    return got is not None and math.isclose(got, want, rel_tol=10.0 ** (1 - digits), abs_tol=1e-300)


def analyze_json(pdla, h5, what):
    rc, so, se = run([pdla, "analyze", h5, "--json"])
    if not check(rc == 0, "%s: analyze --json: exit %d: %s" % (what, rc, se)):
        return None
    try:
        return strict_json(so)
    except ValueError as e:
        check(False, "%s: analyze --json is not JSON (%s): %s" % (what, e, so[-300:]))
        return None


def local_slope_nan(pdla, tmp):
    out = os.path.join(tmp, "rp2")
    rc, so, se = run([pdla, "ensemble", "--clusters", "4", "--target", "2000", "--rg-per-decade", "2", "--out", out,
                      "-q"])
    if not check(rc == 0, "ensemble --rg-per-decade 2: exit %d: %s" % (rc, se)):
        return
    h5 = os.path.join(out, "ensemble.h5")
    d = analyze_json(pdla, h5, "4 clusters, 2 samples a decade")
    if d is None:
        return
    with h5py.File(h5, "r") as f:
        cols = [f["statistics/" + k][()] for k in ("slope_N", "slope_D_f", "slope_D_f_lo", "slope_D_f_hi")]
        attrs = dict(f["statistics"].attrs)
    rows = d.get("local_slope", [])
    check(len(rows) == len(cols[0]) and any(math.isnan(v) for c in cols for v in c),
          "local_slope: %d rows, file %d (and some NaN, or this case tests nothing)" % (len(rows), len(cols[0])))
    for i, row in enumerate(rows):
        check(len(row) == 4 and all(same(row[k], float(cols[k][i]), 6) for k in range(4)),
              "local_slope[%d] = %s, file %s" % (i, row, [float(c[i]) for c in cols]))
    for key in ("D_f", "D_f_lo", "D_f_hi", "D_f_cluster_sd", "corr_D"):
        if key in attrs:
            check(same(d.get(key), float(attrs[key]), 15), "%s = %s, file %s" % (key, d.get(key), attrs[key]))


def correction_notes(pdla, tmp):
    """The correction fit's notes in analyze: nu at an end of [0.2, 2] (the
    golden section stops a hair inside it: 1.9999999999999998 printed no
    note) and B at its cap, |B N^-nu| = 0.9 at the smallest N fitted, which
    is the first grid point at or above 30 (37 at 7 samples a decade: the
    test at 30 could note a cap B had not reached). corr_correction_max in
    the file is that |B N^-nu|, recomputed here from /gyration/N."""
    for clusters, seed, pd in ((1, 1, 100), (4, 20, 100), (3, 5, 7)):
        out = os.path.join(tmp, "cn%d-%d-%d" % (clusters, seed, pd))
        rc, so, se = run([pdla, "ensemble", "--clusters", str(clusters), "--target", "3000", "--seed", str(seed),
                          "--rg-per-decade", str(pd), "--out", out, "-q"])
        if not check(rc == 0, "ensemble %s: exit %d: %s" % (out, rc, se)):
            continue
        h5 = os.path.join(out, "ensemble.h5")
        with h5py.File(h5, "r") as f:
            a = dict(f["statistics"].attrs)
            n = f["gyration/N"][()]
        rc, text, se = run([pdla, "analyze", h5])
        check(rc == 0, "%s: analyze exit %d" % (out, rc))
        if int(a["corr_ok"]) != 1:
            continue
        nu, B = float(a["corr_nu"]), float(a["corr_B"])
        first = min(x for x in n if x >= int(a["corr_n_lo"]))
        cmax = abs(B) * first ** -nu
        check(math.isclose(float(a["corr_correction_max"]), cmax, rel_tol=1e-9),
              "%s: corr_correction_max %s, |B N^-nu| at N = %d is %s" % (out, a["corr_correction_max"], first, cmax))
        check(cmax <= 0.9 * (1 + 1e-9), "%s: |B N^-nu| = %s above the cap 0.9" % (out, cmax))
        at_end = nu <= 0.2 * (1 + 1e-6) or nu >= 2.0 * (1 - 1e-6)
        check(("end of its range" in text) == at_end, "%s: nu %r, the end-of-range note %s" %
              (out, nu, "missing" if at_end else "given"))
        capped = cmax >= 0.9 * (1 - 1e-6)
        check(("B at its cap" in text) == capped, "%s: |B N^-nu| %r, the cap note %s" %
              (out, cmax, "missing" if capped else "given"))


def one_cluster(pdla, tmp):
    """M = 1: every bootstrap resample is that cluster, so no interval is
    given (it had zero width: [D_f, D_f], sd 0): NaN in ensemble.h5 (D_f_lo,
    D_f_hi, D_f_boot_sd, the slope bands, the correction fit's intervals)
    like se_rg and D_f_cluster_sd, null in --json, "n/a" in the text; the
    same with M = 2 gives real intervals of nonzero width."""
    for m in (1, 2):
        out = os.path.join(tmp, "m%d" % m)
        rc, so, se = run([pdla, "ensemble", "--clusters", str(m), "--target", "3000", "--out", out, "-q"])
        if not check(rc == 0, "ensemble --clusters %d: exit %d: %s" % (m, rc, se)):
            continue
        h5 = os.path.join(out, "ensemble.h5")
        with h5py.File(h5, "r") as f:
            st = f["statistics"]
            a = {k: float(st.attrs[k]) for k in ("D_f", "D_f_lo", "D_f_hi", "D_f_boot_sd", "D_f_cluster_sd",
                                                  "corr_D_lo", "corr_D_hi", "corr_A_lo", "corr_A_hi")}
            bands = list(st["slope_D_f_lo"][()]) + list(st["slope_D_f_hi"][()])
            se_rg = list(st["se_rg_diam"][()])
        what = "%d cluster%s" % (m, "s" if m > 1 else "")
        check(math.isfinite(a["D_f"]), "%s: D_f %s" % (what, a["D_f"]))
        nan_keys = [k for k in a if k != "D_f" and math.isnan(a[k])]
        if m == 1:
            check(len(nan_keys) == len(a) - 1, "%s: finite %s, want NaN" %
                  (what, {k: v for k, v in a.items() if k != "D_f" and k not in nan_keys}))
            check(bands and all(math.isnan(v) for v in bands), "%s: slope bands not all NaN" % what)
            check(se_rg and all(math.isnan(v) for v in se_rg), "%s: se_rg_diam not NaN" % what)
        else:
            check(not nan_keys and a["D_f_lo"] < a["D_f_hi"] and a["D_f_boot_sd"] > 0,
                  "%s: intervals %s" % (what, a))
        d = analyze_json(pdla, h5, what)
        if d is not None:
            for k in a:
                check(same(d.get(k), a[k], 15), "%s: --json %s = %s, file %s" % (what, k, d.get(k), a[k]))
        rc, so, se = run([pdla, "analyze", h5])
        if not check(rc == 0, "%s: analyze: exit %d: %s" % (what, rc, se)):
            continue
        lines = so.splitlines()
        df = [x for x in lines if x.startswith("D_f ")]
        if m == 1:
            check(len(df) == 1 and "interval [n/a]" in df[0] and "nan" not in so,
                  "%s: analyze text: %s" % (what, "\n".join(lines[:6])))
            check(any(x.startswith("per-cluster D_f") and "sd n/a" in x for x in lines),
                  "%s: per-cluster sd not n/a" % what)
        else:
            check(len(df) == 1 and "n/a" not in so, "%s: analyze text: %s" % (what, "\n".join(lines[:6])))


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: test_ens_json.py PDLA")
    pdla = os.path.abspath(sys.argv[1])
    with tempfile.TemporaryDirectory() as tmp:
        local_slope_nan(pdla, tmp)
        correction_notes(pdla, tmp)
        one_cluster(pdla, tmp)
    TALLY.done()


if __name__ == "__main__":
    main()
