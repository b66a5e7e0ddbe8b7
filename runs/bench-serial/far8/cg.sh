#!/bin/bash
# cg.sh N BIN... : callgrind instruction count + jumps for each binary (2D, seed 1)
# BIN: folder of the binaries named on the command line; TMP: scratch folder.
BIN=${BIN:-bin}; TMP=${TMP:-/tmp}
N=$1; shift
for b in "$@"; do
  ir=$(nice -n 10 valgrind --tool=callgrind --callgrind-out-file=$TMP/cg.$b.$N.out $BIN/$b --dim 2 --target $N --seed 1 --no-output -q --stats-json $TMP/cg.$b.json 2>&1 | grep refs | awk '{print $NF}' | tr -d ,)
  /usr/bin/python3 -c "import json;d=json.load(open('$TMP/cg.$b.json'));j=d['jumps'];print('$b N=$N Ir=$ir jumps/p=%.4f Ir/jump=%.1f Ir/p=%.0f rg=%.4f'%(j/$N,$ir/j,$ir/$N,d['rg_diam']))"
done
