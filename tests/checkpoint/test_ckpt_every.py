#!/usr/bin/python3
"""test_ckpt_every.py PDLA - `--checkpoint-every T` reaches checkpoint.h5 in seconds.

README (Checkpoints and resume): T is seconds, or with a suffix s, m, h
(`90`, `30m`, `1.5h`), and each checkpoint records it as the root attribute
`schedule_every_seconds` (DLA, DLCA and event). One short run per value,
each writing its final checkpoint: the attribute must be 90 for `90` and
`90s`, 1800 for `30m`, 5400 for `1.5h` (DLA), and 90 and 5400 for the DLCA
and event commands, which parse T with the same function (cli-parse
checks the parser alone on more values).
Prints one line per failure and "N checks, N failed"; exit 1 on a failure.
"""
import os
import shutil
import subprocess
import sys
import tempfile

import h5py

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "reliab"))
from reliab_util import Tally  # noqa: E402

TALLY = Tally()
check = TALLY.check
PDLA = os.path.abspath(sys.argv[1])
MODELS = {
    "dla": (["--dim", "2", "--target", "300", "--seed", "2", "-q"],
            [("90", 90.0), ("90s", 90.0), ("30m", 1800.0), ("1.5h", 5400.0)]),
    "dlca": (["--model", "dlca", "--dim", "2", "--box", "32", "--fill", "0.05", "--seed", "1", "-q"],
             [("90", 90.0), ("1.5h", 5400.0)]),
    "event": (["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--t-max", "2",
               "--seed", "3", "--quiet"], [("90", 90.0), ("1.5h", 5400.0)]),
}


def main():
    tmp = tempfile.mkdtemp(prefix="pdla-ckpt-every.")
    try:
        for model, (args, cases) in MODELS.items():
            for value, want in cases:
                d = os.path.join(tmp, "%s-%s" % (model, value))
                p = subprocess.run([PDLA] + args + ["--checkpoint-every", value, "--out", d], capture_output=True,
                                   text=True, stdin=subprocess.DEVNULL, timeout=120)
                if not check(p.returncode == 0, "%s --checkpoint-every %s: exit %d: %s" %
                             (model, value, p.returncode, p.stderr.strip()[-300:])):
                    continue
                ck = os.path.join(d, "checkpoint.h5")
                if not check(os.path.exists(ck), "%s --checkpoint-every %s: no checkpoint.h5" % (model, value)):
                    continue
                with h5py.File(ck, "r") as f:
                    got = f.attrs.get("schedule_every_seconds")
                check(got is not None and float(got) == want, "%s --checkpoint-every %s: schedule_every_seconds %r, "
                      "want %g" % (model, value, got, want))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    TALLY.done()


if __name__ == "__main__":
    main()
