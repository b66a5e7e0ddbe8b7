#!/bin/sh
# runs/dlca/render.sh - the pictures render-2d.png and render-3d.png (pdla render of a
# DLCA cluster.h5, coloured by cluster; 3D seen along z, nearer monomers brighter) and
# `pdla analyze` of the same files (analyze.txt).
set -eu
build/pdla --model dlca --dim 2 --box 1024x1024 --fill 0.01 --until-clusters 30 --seed 1 --out /tmp/dlca-r2 --force -q
build/pdla --model dlca --dim 3 --box 96x96x96 --fill 0.005 --until-clusters 20 --seed 1 --out /tmp/dlca-r3 --force -q
build/pdla render /tmp/dlca-r2/cluster.h5 -o runs/dlca/render-2d.png --size 512 --force
build/pdla render /tmp/dlca-r3/cluster.h5 -o runs/dlca/render-3d.png --size 384 --force
{ build/pdla analyze /tmp/dlca-r2/cluster.h5; build/pdla analyze /tmp/dlca-r3/cluster.h5; } >runs/dlca/analyze.txt
