/work/big/bias8bin/pdla --dim 2 --target 1e5 --seed SEED --no-output -q --stats-json FILE 
