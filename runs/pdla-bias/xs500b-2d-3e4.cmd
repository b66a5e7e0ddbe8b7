/work/big/f1src/build/pdla --dim 2 --target 3e4 --seed SEED --no-output -q --stats-json FILE --threads 8 --serial-until 1e4
