# paraview_render.py - run by pvpython (through scripts/paraview-render):
# draw the particles of a pdla output (its .xdmf2 sidecar, or an exported
# .ply) as lit spheres in ParaView and save a PNG. See paraview-render.
import argparse
import os
import sys

from paraview.simple import (ColorBy, CreateView, GetColorTransferFunction, OpenDataFile,
                             Render, SaveScreenshot, Show)

ap = argparse.ArgumentParser(prog="paraview-render")
ap.add_argument("file", help="cluster.xdmf2 (written beside cluster.h5) or an exported .ply")
ap.add_argument("-o", "--output", required=True, help="PNG to write (refused if it exists)")
ap.add_argument("--size", type=int, default=1024, help="width = height in pixels (default 1024)")
ap.add_argument("--color", default=None,
                help="point array to colour by: arrival, distance (default: arrival if present)")
ap.add_argument("--elevation", type=float, default=20.0, help="camera elevation, degrees (3D)")
ap.add_argument("--azimuth", type=float, default=30.0, help="camera azimuth, degrees (3D)")
ap.add_argument("--no-ssao", action="store_true", help="no screen-space ambient occlusion")
ap.add_argument("--force", action="store_true", help="replace an existing PNG")
a = ap.parse_args()
if not 16 <= a.size <= 8192:
    sys.exit("paraview-render: --size: want 16..8192")
if os.path.lexists(a.output) and not a.force:
    sys.exit("paraview-render: %s exists; not overwriting it (use --force)" % a.output)

src = OpenDataFile(os.path.abspath(a.file))
if src is None:
    sys.exit("paraview-render: ParaView has no reader for %s" % a.file)
src.UpdatePipeline()
info = src.GetDataInformation()
if info.GetNumberOfPoints() == 0:
    sys.exit("paraview-render: %s holds no points" % a.file)
b = info.GetBounds()
flat = b[5] - b[4] == 0  # 2D clusters lie in z = 0

view = CreateView("RenderView")
view.ViewSize = [a.size, a.size]
view.OrientationAxesVisibility = 0
view.UseColorPaletteForBackground = 0
view.Background = [1.0, 1.0, 1.0]
disp = Show(src, view)
# Every particle a shaded sphere of its true radius (0.5 diameters): the
# lighting and, unless --no-ssao, ambient occlusion are the depth cues.
disp.SetRepresentationType("Point Gaussian")
disp.ShaderPreset = "Sphere"
disp.GaussianRadius = 0.5
names = [info.GetPointDataInformation().GetArrayInformation(i).GetName()
         for i in range(info.GetPointDataInformation().GetNumberOfArrays())]
color = a.color or ("arrival" if "arrival" in names else "distance" if "distance" in names else None)
if color is not None:
    if color not in names:
        sys.exit("paraview-render: %s has no point array %s (it has %s)" % (a.file, color, ", ".join(names) or "none"))
    ColorBy(disp, ("POINTS", color))
    lut = GetColorTransferFunction(color)
    lut.ApplyPreset("Inferno (matplotlib)", True)
    disp.RescaleTransferFunctionToDataRange(True, False)
else:
    disp.DiffuseColor = [0.85, 0.45, 0.1]
    disp.AmbientColor = [0.85, 0.45, 0.1]
if not flat and not a.no_ssao:
    view.UseAmbientOcclusion = 1

Render(view)  # paraview.simple resets the camera on a view's first render
view.ResetCamera()
cam = view.GetActiveCamera()
if not flat:
    cam.Elevation(a.elevation)
    cam.Azimuth(a.azimuth)
    cam.OrthogonalizeViewUp()
view.ResetCamera()
cam.Zoom(1.1 if flat else 1.3)
Render(view)
tmp = "%s.tmp.%d.png" % (a.output, os.getpid())
try:
    SaveScreenshot(tmp, view, ImageResolution=[a.size, a.size], CompressionLevel="9")
    if not os.path.exists(tmp):
        sys.exit("paraview-render: ParaView wrote no picture")
    if a.force:
        os.replace(tmp, a.output)
    else:
        os.link(tmp, a.output)  # fails if the PNG appeared meanwhile
        os.unlink(tmp)
finally:
    if os.path.exists(tmp):
        os.unlink(tmp)
