/work/big/bias8bin/pdla --dim 2 --target 2e4 --seed SEED --no-output -q --stats-json FILE 
