/tmp/bias2bin/pdla --dim 2 --target 1e5 --seed SEED --no-output -q --stats-json FILE --threads 16 --serial-until 1e4
