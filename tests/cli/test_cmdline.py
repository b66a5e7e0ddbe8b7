#!/usr/bin/env python3
"""The command line stored for provenance (/Code command_line) reads back,
through a POSIX shell's word splitting, as the words that were typed: for
every model (DLA, event, DLCA) and the ensemble command, with an output
folder whose name holds a space and single quotes (which the event and DLCA
commands stored unquoted before, so a pasted line named another folder).
Also through a real POSIX shell (sh -c, the program replaced by one that
prints its words): pdla run as b=c/pdla (a first word with '=', which the
shell read as an assignment before it was quoted) with an output folder
named with ~ # * ? [ ] ! { , } ; & | < > ( ) ` " \ tab, newline, non-ASCII,
$x and quotes.
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


PRINTER = "#!/bin/sh\nprintf '%s\\0' \"$0\" \"$@\"\n"


def through_sh(pdla):
    """The stored line run by sh, with the program (b=c/pdla, or pdla on the
    PATH for the ensemble) one that prints its words: the typed words back?"""
    fails = 0
    with tempfile.TemporaryDirectory() as t:
        run_dir, eval_dir = os.path.join(t, "run"), os.path.join(t, "eval")
        for d in (run_dir, eval_dir):
            os.makedirs(os.path.join(d, "b=c"))
        os.symlink(os.path.abspath(pdla), os.path.join(run_dir, "b=c", "pdla"))
        for p in (os.path.join(eval_dir, "b=c", "pdla"), os.path.join(eval_dir, "pdla")):
            with open(p, "w") as f:
                f.write(PRINTER)
            os.chmod(p, 0o755)
        name = "~r #*?[a]!{x,y};&|<>()`\"\\ \t\n\u00e9 $x 'q' %s"
        cases = [
            ("dla", ["b=c/pdla", "--target", "200", "--out", None, "-q"], "cluster.h5"),
            ("event", ["b=c/pdla", "--model", "event", "--dim", "2", "--particles", "50", "--packing", "0.05",
                       "--out", None, "--no-progress"], "cluster.h5"),
            ("dlca", ["b=c/pdla", "--model", "dlca", "--box", "32", "--count", "20", "--out", None], "cluster.h5"),
            ("ensemble", ["b=c/pdla", "ensemble", "--clusters", "2", "--target", "100", "--out", None],
             "ensemble.h5"),
        ]
        for model, argv, out in cases:
            d = name % model
            argv = [d if a is None else a for a in argv]
            r = subprocess.run(argv, cwd=run_dir, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            if r.returncode != 0:
                print(f"FAIL sh {model}: exit {r.returncode}: {r.stderr.strip()}")
                fails += 1
                continue
            cmd = stored(os.path.join(run_dir, d, out))
            env = dict(os.environ, PATH=eval_dir + os.pathsep + os.environ.get("PATH", ""))
            e = subprocess.run(["sh", "-c", cmd], cwd=eval_dir, env=env, capture_output=True)
            got = [w.decode() for w in e.stdout.split(b"\0")[:-1]]
            want = (["pdla"] if model == "ensemble" else ["b=c/pdla"]) + argv[1:]
            if model == "ensemble":
                got[0] = os.path.basename(got[0]) if got else None
            if e.returncode != 0 or got != want:
                print(f"FAIL sh {model}: stored {cmd!r} runs in sh as {got} (exit {e.returncode}, "
                      f"{e.stderr.decode().strip()!r}), typed {want}")
                fails += 1
            else:
                print(f"ok sh {model}: {cmd!r}")
    return fails


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
    fails += through_sh(pdla)
    print(f"{fails} failed")
    return 1 if fails else 0


if __name__ == "__main__":
    sys.exit(main())
