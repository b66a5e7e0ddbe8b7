#!/bin/bash
# ab.sh N SEED BIN... : run each binary once (in the given order), print a line each
# BIN: folder of the binaries named on the command line; TMP: scratch folder.
BIN=${BIN:-bin}; TMP=${TMP:-/tmp}
N=$1; S=$2; shift 2
for b in "$@"; do
  /usr/bin/time -f "%U %M" -o $TMP/t.$$ nice -n 10 $BIN/$b --dim 2 --target $N --seed $S --no-output -q --stats-json $TMP/s.$$.json
  read u m < $TMP/t.$$
  /usr/bin/python3 -c "import json,sys;d=json.load(open('$TMP/s.$$.json'));n=d['particles'];print('$b N=$N seed=$S user_s=$u maxrss_kb=$m jumps/p=%.4f returns/p=%.4f rg=%.6f'%(d['jumps']/n,d['returns']/n,d['rg_diam']))"
done
