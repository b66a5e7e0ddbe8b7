/work/big/bin9/pdla-core1 --dim 2 --target 1e5 --seed SEED --no-output -q --stats-json FILE --threads 2 --serial-until 1e4
