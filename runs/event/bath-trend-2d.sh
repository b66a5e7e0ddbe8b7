#!/usr/bin/env bash
# bath-trend-2d.sh - D_f against the bath's packing in 2D, the sticky kind
# fixed (2000 sticky disks, packing 0.02 in a box of 280 diameters, stop at
# 1000 stuck): the crossover from ballistic-like growth (no bath: mean free
# path 13.9 diameters) to DLA-like (bath 0.2: 1.26). README "A bath that
# never sticks". From the repository root after `ninja -C build`:
#   nice -n 10 runs/event/bath-trend-2d.sh "5000:0.07:12 10000:0.12:8" > runs/event/bath-trend-2d.txt
# Each NBATH:PACKING:SEEDS runs bath.sh 2000 NBATH PACKING 1000 SEEDS 8 with
# REUSE=1 (only missing runs are made), its whole output kept in
# runs/event/bath-2d-pPACKING.txt; then one table over the common window
# r in [4, 12.5] (the control's 0.4 R_max; bath.sh's estimate, window.c):
# per set the mean D_f and its error sd / sqrt(seeds), the mean R_max
# (farthest stuck centre) and its error, and the packing of the cluster
# inside r = 8 (the seed counted, as in window.c) and its error. The bath of 0.2 (20000 bath, total 0.22) is bath-2d.txt's
# (session 7, 3 seeds, not rerun here: 220 CPU-s a run): its row is quoted
# from that file.
set -eu
b=build/pdla
o=runs/event/out
w=build/window
for spec in $1; do
    IFS=: read -r nb eta seeds <<< "$spec"
    REUSE=1 runs/event/bath.sh 2000 "$nb" "$eta" 1000 "$seeds" 8 > "runs/event/bath-2d-p$eta.txt"
done
git log -1 --format='# commit %h (%cd)' --date=iso
echo "# made by: runs/event/bath-trend-2d.sh \"$1\""
L=$($b info "$o/ctrl_2d_n2000_p0.02_m1000_s1/cluster.h5" | awk '$1 == "box_side" { print $2 }')
c=$(awk -v L="$L" 'BEGIN { printf "%.17g %.17g", L / 2, L / 2 }')
row() { # row NAME LAMBDA CX CY FILES...: one line of the table
    local name=$1 lam=$2 cx=$3 cy=$4
    shift 4
    local ph
    ph=$(for f in "$@"; do # the packing inside r = 8 of each file: M(8) (pi / 4) / (pi 64)
        awk -F, -v cx="$cx" -v cy="$cy" 'NR > 1 && ($1 - cx) ^ 2 + ($2 - cy) ^ 2 <= 64 { k++ } END { print k / 256 }' "$f"
    done | awk '{ s += $1; s2 += $1 * $1; k++ } END { m = s / k; printf "%.3f +- %.3f", m, sqrt((s2 - k * m * m) / (k - 1) / k) }')
    $w 2 4 12.5 "$cx" "$cy" "$@" | awk -v n="$name" -v l="$lam" -v ph="$ph" '
        $1 == "file" { r += $6; r2 += $6 * $6; k++ }
        $1 ~ /^D_f/ { df = $3; se = $7 }
        END { m = r / k; s = sqrt((r2 - k * m * m) / (k - 1) / k)
              lw = (l > 0) ? sprintf("%.2g-%.2g", 4 / l, 12.5 / l) : "-"
              ls = (l > 0) ? sprintf("%.3g", l) : "-"
              printf "| %-28s | %6s | %-9s | %5d | %.3f +- %.3f | %5.1f +- %.1f | %s |\n", n, ls, lw, k, df, se, m, s, ph }'
}
echo "## 2000 sticky (packing 0.02), stop at 1000 stuck; D_f over r in [4, 12.5]; phi_c(8) the cluster's packing inside r = 8"
echo "| set (bath packing)           | lambda | r/lambda  | seeds | D_f [4, 12.5]  | R_max        | phi_c(8)        |"
echo "|------------------------------|--------|-----------|-------|----------------|--------------|-----------------|"
row "no bath (control), 0" 13.884 $c $o/ctrl_2d_n2000_p0.02_m1000_s{1..8}.csv
for spec in $1; do
    IFS=: read -r nb eta seeds <<< "$spec"
    lam=$(awk -v e="$eta" 'BEGIN { printf "%.4g", 3.14159265358979 / (8 * sqrt(2) * e) }')
    bpk=$(awk -v e="$eta" 'BEGIN { printf "%.3g", e - 0.02 }')
    row "bath $bpk ($nb)" "$lam" $c $(for s in $(seq 1 "$seeds"); do echo "$o/bath_2d_n2000_b${nb}_p${eta}_m1000_s$s.csv"; done)
done
# the bath of 0.2 from bath-2d.txt: D_f over [4, 12.5] from its common-window
# line, R_max from its per-file lines, phi_c(8) from its bath profile
awk '/^#   bath: D_f\[4,12.5\]/ { df = $5; se = $9 }
     /^#   file .*bath_2d_n2000_b20000/ { r += $7; r2 += $7 * $7; k++ }
     /^## event, sticky in a bath/ { on = 1 } /^## control/ { on = 0 }
     on && $1 == "8.00" { phi = $3 }
     END { m = r / k; s = sqrt((r2 - k * m * m) / (k - 1) / k)
           printf "| %-28s | %6s | %-9s | %5d | %.3f +- %.3f | %5.1f +- %.1f | %.3f |\n", "bath 0.2 (20000) (*)", "1.26",
                  "3.2-9.9", k, df, se, m, s, phi }' runs/event/bath-2d.txt
row "pdla DLA (1000)" 0 0 0 $o/bath_dla_1000_s{1..8}.csv
row "BPCA (1000)" 0 0 0 $o/bath_bpca_1000_s{1..8}.csv
echo "(*) quoted from bath-2d.txt (session 7's runs, not rerun: 220 CPU-s each)"
echo "## CPU per bath run (user s) and events"
for spec in $1; do
    IFS=: read -r nb eta seeds <<< "$spec"
    grep '^#   stuck' "runs/event/bath-2d-p$eta.txt" | head -"$seeds" |
        awk -v e="$eta" '{ for (i = 1; i <= NF; i++) { if ($i == "events") ev += $(i + 1); if ($i == "user") { u += $(i - 1) } } k++ }
        END { printf "#   total packing %s: %d runs, mean %.1f CPU-s, %.3g events each\n", e, k, u / k, ev / k }'
done
