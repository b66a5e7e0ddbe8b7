#!/bin/bash
# pj.sh BIN N SEEDS... : mean jumps/p (env passes F13_*); prints bound violations
b=$1; n=$2; shift 2
for s in "$@"; do
  $b --dim 2 --target $n --seed $s --no-output -q --stats-json /tmp/far13/pjx.$$.json 2>/tmp/far13/pjx.$$.err
  grep -h VIOL /tmp/far13/pjx.$$.err >&2
  python3 -c "import json;s=json.load(open('/tmp/far13/pjx.$$.json'));print(s['jumps']/s['particles'])"
done | awk -v l="$F13_PROTO/$F13_CAP/$F13_WHERE/$F13_FB" '{s+=$1; a=a" "sprintf("%.3f",$1)} END {printf "%s mean %.3f :%s\n", l, s/NR, a}'
rm -f /tmp/far13/pjx.$$.*
