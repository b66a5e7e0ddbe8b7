/work/big/bias7bin/pdla --dim 2 --target 1e5 --seed SEED --no-output -q --stats-json FILE --reference-walkers 8 --serial-until 1e4
