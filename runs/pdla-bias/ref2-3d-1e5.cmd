seeds 1001-1320: /tmp/bias6bin/pdla --dim 3 --target 1e5 --seed SEED --no-output -q --stats-json FILE --reference-walkers 2 --serial-until 1e4
seeds 1321-1760: /work/big/bin10/pdla --dim 3 --target 1e5 --seed SEED --no-output -q --stats-json FILE --reference-walkers 2 --serial-until 1e4
