#!/usr/bin/env bash
# pictures-3d.sh - pictures of the 3D event clusters that ballistic.sh grew
# (N = 1e4, p = 1, packing 1e-3 / 0.05 / 0.3: mean free path 118 / 2.4 /
# 0.39 diameters), stuck particles coloured by arrival (dark first):
#   cluster_3d_p*.png     `pdla render` (projection along z, 320 px)
#   cluster_3d_p*_pv.png  scripts/paraview-render (lit spheres, 360 px)
# Run from the repository root after runs/event/ballistic.sh:
#   nice -n 10 runs/event/pictures-3d.sh
set -eu
for eta in 0.001 0.05 0.3; do
    dir=runs/event/out/ball_d3_p$eta
    build/pdla render "$dir/cluster.h5" -o "runs/event/cluster_3d_p$eta.png" --size 320 --force
    scripts/paraview-render "$dir/cluster.xdmf2" -o "runs/event/cluster_3d_p${eta}_pv.png" --size 360 --force
done
ls -l runs/event/cluster_3d_p*.png
