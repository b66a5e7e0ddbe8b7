# pv_ensemble.py - run by pvpython: open an ensemble sidecar (FILE.xdmf2)
# with ParaView's own choice of reader (OpenDataFile, as File > Open does)
# and print one JSON line: the reader, and per block (cluster) its points,
# cells, bounds, first point and the range of each point array.
# Usage: pvpython --force-offscreen-rendering pv_ensemble.py FILE
import json
import sys

from paraview import servermanager as sm
from paraview.simple import OpenDataFile

r = OpenDataFile(sys.argv[1])
if r is None:
    print(json.dumps({"reader": None}))
    sys.exit(3)
r.UpdatePipeline()
d = sm.Fetch(r)
out = {"reader": r.GetXMLName(), "multiblock": bool(d.IsA("vtkMultiBlockDataSet")), "blocks": []}
blocks = [d.GetBlock(i) for i in range(d.GetNumberOfBlocks())] if out["multiblock"] else [d]
for b in blocks:
    e = {"points": b.GetNumberOfPoints(), "cells": b.GetNumberOfCells(), "bounds": list(b.GetBounds()),
         "first": list(b.GetPoint(0)) if b.GetNumberOfPoints() else None, "arrays": {}}
    pd = b.GetPointData()
    for i in range(pd.GetNumberOfArrays()):
        a = pd.GetArray(i)
        e["arrays"][a.GetName()] = {"range": list(a.GetRange()), "tuples": a.GetNumberOfTuples(),
                                    "last": a.GetTuple1(a.GetNumberOfTuples() - 1)}
    out["blocks"].append(e)
print(json.dumps(out))
