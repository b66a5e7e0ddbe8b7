#!/bin/bash
# ab.sh N_SERIAL TARGET ROUNDS BIN_A BIN_B: --threads 2 runs alternated, one line each
ns=$1 tg=$2 rounds=$3; shift 3
for r in $(seq ${FIRST:-1} $rounds); do for b in "$@"; do
  $b --dim 2 --target $tg --serial-until $ns --threads 2 --seed $r --no-output -q --stats-json /tmp/conc21/s.json
  /usr/bin/python3 -c "
import json,sys;d=json.load(open('/tmp/conc21/s.json'))
print('%s seed %d %s->%s wcpu %.2f par %.2f jumps/p %.2f rss %.1fMiB' % ('$b'.split('/')[-1], $r, '$ns', '$tg', d['worker_cpu_seconds'], d['parallel_seconds'], d['jumps']/d['particles'], d['peak_rss_bytes']/2**20))"
done; done
