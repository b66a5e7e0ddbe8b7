# pv_check.py - run by pvpython: open FILE with ParaView's own choice of
# reader (OpenDataFile, as File > Open does) and print one JSON line:
# reader, points, cells, bounds, and per point array its range and values
# at a few rows. Usage: pvpython pv_check.py FILE
import json
import sys

from paraview import servermanager as sm
from paraview.simple import OpenDataFile

path = sys.argv[1]
r = OpenDataFile(path)
if r is None:
    print(json.dumps({"reader": None}))
    sys.exit(3)
r.UpdatePipeline()
d = sm.Fetch(r)
if d.IsA("vtkMultiBlockDataSet"):
    d = d.GetBlock(0)
out = {"reader": r.GetXMLName(), "points": d.GetNumberOfPoints(),
       "cells": d.GetNumberOfCells(), "bounds": list(d.GetBounds()), "arrays": {}}
n = d.GetNumberOfPoints()
rows = sorted({0, 1, n // 2, n - 1}) if n > 0 else []
out["rows"] = rows
out["xyz"] = [list(d.GetPoint(i)) for i in rows]
pd = d.GetPointData()
for i in range(pd.GetNumberOfArrays()):
    a = pd.GetArray(i)
    out["arrays"][a.GetName()] = {"range": list(a.GetRange()), "tuples": a.GetNumberOfTuples(),
                                 "at": [a.GetTuple1(j) for j in rows]}
print(json.dumps(out))
