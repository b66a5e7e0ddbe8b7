#!/bin/sh
exec taskset -c 1 /work/big/bf1/pdla "$@"
