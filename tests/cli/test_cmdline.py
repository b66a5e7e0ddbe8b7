#!/usr/bin/env python3
"""The command line stored for provenance (/Code command_line) reads back,
through a POSIX shell's word splitting, as the words that were typed: for
every model (DLA, event, DLCA) and the ensemble command, with an output
folder whose name holds a space and single quotes (which the event and DLCA
commands stored unquoted before, so a pasted line named another folder).
Usage: test_cmdline.py PDLA"""
import os
import shlex
import subprocess
import sys
import tempfile

import h5py


def stored(path):
    with h5py.File(path, "r") as f:
        v = f["/Code"].attrs["command_line"]
    return v.decode() if isinstance(v, bytes) else str(v)


def main():
    pdla = sys.argv[1]
    fails = 0
    with tempfile.TemporaryDirectory() as t:
        cases = [
            ("dla", [pdla, "--target", "200", "--out", None, "-q"], "cluster.h5", pdla),
            ("event", [pdla, "--model", "event", "--dim", "2", "--particles", "50", "--packing", "0.05",
                       "--out", None, "--no-progress"], "cluster.h5", pdla),
            ("dlca", [pdla, "--model", "dlca", "--box", "32", "--count", "20", "--out", None],
             "cluster.h5", pdla),
            ("ensemble", [pdla, "ensemble", "--clusters", "2", "--target", "100", "--out", None],
             "ensemble.h5", "pdla"),
        ]
        for name, argv, out, first in cases:
            d = os.path.join(t, f"run {name} 'q' $x")
            argv = [d if a is None else a for a in argv]
            r = subprocess.run(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if r.returncode != 0:
                print(f"FAIL {name}: exit {r.returncode}: {r.stderr.strip()}")
                fails += 1
                continue
            cmd = stored(os.path.join(d, out))
            want = [first] + argv[1:]
            got = shlex.split(cmd)
            if got != want:
                print(f"FAIL {name}: stored {cmd!r} splits into {got}, typed {want}")
                fails += 1
            else:
                print(f"ok {name}: {cmd}")
    print(f"{fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
