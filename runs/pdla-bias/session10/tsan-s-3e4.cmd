/work/big/tsan/pdla --dim 2 --target 3e4 --seed SEED --no-output -q --stats-json FILE --serial-until 2000
