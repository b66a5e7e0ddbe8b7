/work/big/bin9n/pdla --dim 2 --target 1e5 --seed SEED --no-output -q --stats-json FILE --threads 8 --serial-until 1e4
