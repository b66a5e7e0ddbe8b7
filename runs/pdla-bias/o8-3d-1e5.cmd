/work/big/b10/core1.sh --dim 3 --target 1e5 --seed SEED --no-output -q --stats-json FILE --threads 8 --serial-until 1e4
