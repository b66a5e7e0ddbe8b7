/work/big/bin10/pdla --dim 3 --target 1e5 --seed SEED --no-output -q --stats-json FILE 
