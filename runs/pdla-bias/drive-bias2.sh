#!/usr/bin/env bash
# drive.sh JOBNAME ARM16 ARM4 OPTS16... -- OPTS4...  : alternate chunks of 100 seeds
cd /work/wt/bias2
job=$1 a16=$2 a4=$3 mode=$4   # mode: threads or ref
export PDLA=/tmp/bias2bin/pdla
for ((c = 1001; c <= 3000; c += 100)); do
  e=$((c + 99))
  if [ $mode = threads ]; then
    nice -n 10 scripts/pdla-bias-ensemble $a16 $c $e --threads 16 --serial-until 1e4
    [ $c -le 2000 ] && nice -n 10 scripts/pdla-bias-ensemble $a4 $c $e --threads 4 --serial-until 1e4
  else
    nice -n 10 scripts/pdla-bias-ensemble $a16 $c $e --reference-walkers 16 --serial-until 1e4
    [ $c -le 2000 ] && nice -n 10 scripts/pdla-bias-ensemble $a4 $c $e --reference-walkers 4 --serial-until 1e4
  fi
  echo "$(date -u +%T) done seeds ..$e; cpu: $(times | tail -1)" >> /tmp/bias2bin/$job.log
done
