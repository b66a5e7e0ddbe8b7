#!/bin/sh
# all of pdla's threads on CPU 1 only: time slicing, no two walkers running at once
exec taskset -c 1 /work/big/bin10/pdla "$@"
