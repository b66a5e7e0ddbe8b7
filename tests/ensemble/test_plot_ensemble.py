#!/usr/bin/python3
"""test_plot_ensemble.py PDLA PLOT_ENSEMBLE - scripts/plot-ensemble as a user meets it.

README: `scripts/plot-ensemble` draws R_g/N^(1/D), the local slope with its
band and the histogram of the clusters' D_f (PNG; needs python3-h5py and
python3-matplotlib). On an ensemble of 3 2D clusters of 500 particles
(its local slopes, their band and the clusters' D_f finite, so that each
plot has data):
the three PNGs (rg_scaled, local_slope, df_hist) are written and named on
stdout, each a PNG (signature, IHDR) of 400 x 288 pixels that matplotlib
reads back with the data drawn (at least 30 pixels of their colour), the three
pictures differ; a second run without --force refuses (exit 2, the file
named) and leaves them. Skipped (exit 77) without h5py, matplotlib or numpy.
Prints one line per failure and "N checks, N failed"; exit 1 on a failure.
"""
import os
import shutil
import struct
import subprocess
import sys
import tempfile

try:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.image
    import numpy as np
    import h5py
except ImportError as e:
    print("skipped: needs h5py, matplotlib and numpy (%s)" % e)
    sys.exit(77)

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally  # noqa: E402

TALLY = Tally()
check = TALLY.check
PDLA, PLOT = (os.path.abspath(a) for a in sys.argv[1:3])
NAMES = ["rg_scaled.png", "local_slope.png", "df_hist.png"]


def run(args):
    p = subprocess.run(args, capture_output=True, text=True, stdin=subprocess.DEVNULL, timeout=120)
    return p.returncode, p.stdout, p.stderr


def png_size(path):
    """(width, height) from a PNG's IHDR, or None if it is not a PNG."""
    with open(path, "rb") as f:
        head = f.read(24)
    if len(head) < 24 or head[:8] != b"\x89PNG\r\n\x1a\n" or head[12:16] != b"IHDR":
        return None
    return struct.unpack(">II", head[16:24])


def main():
    tmp = tempfile.mkdtemp(prefix="pdla-plot-ens.")
    try:
        run_checks(tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    TALLY.done()


def run_checks(tmp):
    ens = os.path.join(tmp, "e")
    rc, _, err = run([PDLA, "ensemble", "--clusters", "3", "--target", "500", "--seed", "3", "--out", ens, "-q"])
    if not check(rc == 0, "pdla ensemble: exit %d: %s" % (rc, err)):
        return
    with h5py.File(os.path.join(ens, "ensemble.h5"), "r") as f:
        data = [f["statistics/" + k][:] for k in ("slope_D_f", "slope_D_f_lo", "slope_D_f_hi")] + [f["clusters/D_f"][:]]
    check(all(len(a) > 0 and np.isfinite(a).all() for a in data), "the ensemble's local slopes, band or clusters' "
          "D_f are not all finite: the plots would be empty")
    plots = os.path.join(tmp, "plots")
    rc, out, err = run([sys.executable, PLOT, os.path.join(ens, "ensemble.h5"), "-o", plots])
    want = [os.path.join(plots, n) for n in NAMES]
    if not check(rc == 0 and out.split() == want and not err, "plot-ensemble: exit %d, stdout %r, want the three "
                 "paths, stderr %r" % (rc, out, err)):
        return
    pixels = []
    for path in want:
        size = png_size(path) if os.path.exists(path) else None
        if not check(size == (400, 288), "%s: PNG size %s, want (400, 288) (5 x 3.6 in at 80 dpi)" %
                     (os.path.basename(path), size)):
            continue
        img = matplotlib.image.imread(path)
        # The data are drawn in matplotlib's first colour, C0 (#1f77b4: the
        # R_g points, the slope's line, the histogram's bars); axes, text,
        # reference lines and legend frames are other colours.
        c0 = int((np.abs(img[..., :3] * 255 - (31, 119, 180)).max(axis=-1) < 12).sum())
        check(img.shape[:2] == (288, 400) and c0 >= 30,
              "%s: read back %s with %d pixels of the data's colour: nothing drawn" %
              (os.path.basename(path), img.shape, c0))
        pixels.append(img)
    check(len(pixels) == 3 and not any(np.array_equal(pixels[i], pixels[j]) for i, j in ((0, 1), (0, 2), (1, 2))),
          "the three plots are not three different pictures")

    if len(pixels) < 3:
        return
    before = [os.path.getmtime(p) for p in want]
    rc, out, err = run([sys.executable, PLOT, os.path.join(ens, "ensemble.h5"), "-o", plots])
    check(rc == 2 and "exists (use --force)" in err and before == [os.path.getmtime(p) for p in want],
          "a second run without --force: exit %d, %r, want 2 and the plots left alone" % (rc, err))


if __name__ == "__main__":
    main()
