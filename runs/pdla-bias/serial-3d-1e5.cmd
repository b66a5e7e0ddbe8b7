/tmp/bias6bin/pdla --dim 3 --target 1e5 --seed SEED --no-output -q --stats-json FILE 
