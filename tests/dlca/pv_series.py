# pv_series.py - run by pvpython: open a DLCA sidecar FILE with ParaView's
# own choice of reader (OpenDataFile) and print one JSON line: the reader,
# its time steps, and at each step the points' coordinates and the
# "cluster" array (whole: the test's runs are small). Usage: pvpython pv_series.py FILE
import json
import sys

from paraview import servermanager as sm
from paraview.simple import OpenDataFile

r = OpenDataFile(sys.argv[1])
if r is None:
    print(json.dumps({"reader": None}))
    sys.exit(3)
times = [float(v) for v in r.TimestepValues]  # a VectorProperty: empty without time steps
steps = []
for t in times:
    r.UpdatePipeline(t)
    d = sm.Fetch(r)
    if d.IsA("vtkMultiBlockDataSet"):
        d = d.GetBlock(0)
    n = d.GetNumberOfPoints()
    a = d.GetPointData().GetArray("cluster")
    steps.append({"t": t, "points": n, "xyz": [list(d.GetPoint(i)) for i in range(n)],
                  "cluster": [a.GetTuple1(i) for i in range(n)] if a is not None else None})
print(json.dumps({"reader": r.GetXMLName(), "times": times, "steps": steps}))
