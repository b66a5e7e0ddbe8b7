/work/big/b10/core1-f8.sh --dim 2 --target 3e4 --seed SEED --no-output -q --stats-json FILE --threads 8 --serial-until 2000
