#!/usr/bin/python3
"""scene_models.py PDLA WORKDIR - one scene reader for the three models.

The DLA, DLCA and event commands read scene files through src/cli/scene.c
(before, the DLCA and event commands had readers of their own, each as
strict as scene.c by its own code, with other words). So the same hostile
scene must give each command the same single line "pdla: FILE:LINE: reason"
(exit 2, no run directory): a key twice (also as key_name and key-name), a
line over 1024 bytes, a NUL byte, a file over 64 KiB, a line without '=',
without key or value, a bad key, a key that is not a file's (FIFO,
directory), an unknown key and a key that differs from an option in letter
case only. Keys are spelled as the options are: the event model takes `kT`,
and `Seed` is refused in every model with a message naming `seed`.

Each scene starts with the line that picks the model (`model = dlca`, or a
comment for the DLA command, which has no model key), so every case's line
numbers are the same in the three models.
"""
import os
import shutil
import sys

from reliab_util import check, failures, one_line, runner

PDLA, WORK = sys.argv[1], sys.argv[2]
pdla = runner(PDLA, 60)
shutil.rmtree(WORK, ignore_errors=True)
os.makedirs(WORK)

# Per model: the first line, a key with '-' in it, a valid body and its quiet flag.
MODELS = {
    "dla": ("# the DLA model (the default)\n", "serial-until", "target = 300\n", "-q"),
    "dlca": ("model = dlca\n", "until-clusters", "box = 48\nuntil_clusters = 20\n", "-q"),
    "event": ("model = event\n", "t-max", "particles = 10\nt_max = 1\n", "--quiet"),
}

# (name, body after the first line ({k}: the model's key with '-', {k_}: the
# same with '_'), the message after "pdla: FILE", the same words in every model?)
CASES = (
    ("duplicate", "seed = 1\nseed = 2\n", ":3: duplicate key 'seed' (first set on line 2)", True),
    ("duplicate-underscore", "{k_} = 1\n{k} = 2\n", ":3: duplicate key '{k}' (first set on line 2)", True),
    ("long-line", "seed = 1" + " " * 2000 + "\n", ":2: line too long (at most 1024 bytes)", True),
    ("nul", "seed = 1\0 junk\n", ":2: contains a NUL byte (not a text file?)", True),
    ("nul-later", "seed = 1\n\n# c\nx\0\n", ":5: contains a NUL byte (not a text file?)", True),
    ("too-large", "seed = 1\n" + ("#" * 100 + "\n") * 700, ": too large (a scene is at most 65536 bytes)", True),
    ("no-equals", "seed 1\n", ":2: missing '=' (lines are KEY = VALUE)", True),
    ("no-value", "seed =   # none\n", ":2: missing value for 'seed'", True),
    ("no-key", " = 1\n", ":2: missing key before '='", True),
    ("bad-key", "se ed = 1\n", ":2: bad key 'se ed'", True),
    ("bad-key-control", "se\x01ed = 1\n", ":2: bad key 'se?ed'", True),
    ("upper-case", "Seed = 1\n", ":2: unknown key 'Seed' (keys are case-sensitive: 'seed')", True),
    ("upper-case-dash", "{K} = 1\n", ":2: unknown key '{K}' (keys are case-sensitive: '{k}')", True),
    # the tail names the model (or the DLA command's keys): the same prefix
    ("unknown", "colour = red\n", ":2: unknown key 'colour'", False),
)


def scene_file(name, text):
    path = os.path.join(WORK, name + ".scene")
    with open(path, "w", newline="") as fh:
        fh.write(text)
    return path


def refused(tag, args, out, want):
    """Run pdla ARGS --out OUT: exit 2, one line starting `want`, no OUT.
    Returns the line."""
    rc, err = pdla(*(args + ["--out", out]))
    check(rc == 2 and one_line(err) and err.startswith(want),
          "%s: exit %r, %r, want %r..." % (tag, rc, err[-300:], want))
    check(not os.path.exists(out), "%s: a run directory was made" % tag)
    return err


for name, body, want, same in CASES:
    lines = {}
    for model, (first, key, _, _) in MODELS.items():
        fill = {"k": key, "k_": key.replace("-", "_"), "K": key.upper()}
        path = scene_file("%s-%s" % (model, name), first + body.format(**fill))
        tag = "%s %s" % (model, name)
        line = refused(tag, ["--scene", path], os.path.join(WORK, tag.replace(" ", "-") + "-out"),
                       "pdla: " + path + want.format(**fill))
        lines[model] = line.replace(path, "FILE").replace(key.upper(), "KEY").replace(key, "key")
    if same:
        check(len(set(lines.values())) == 1, "%s: the models differ: %r" % (name, lines))

# The unknown key's tail says whose keys these are: each model's command
# read its own scene.
for model, tail in (("dla", " (keys are the long options of pdla --help"), ("dlca", " for model dlca"),
                    ("event", " for model event")):
    path = os.path.join(WORK, model + "-unknown.scene")
    refused(model + " unknown tail", ["--scene", path], os.path.join(WORK, model + "-unknown-tail-out"),
            "pdla: " + path + ":2: unknown key 'colour'" + tail)

# A scene that is not a regular file (a directory; a FIFO would block),
# with the model on the command line for the other two.
lines = set()
for model in MODELS:
    args = ([] if model == "dla" else ["--model", model]) + ["--scene", WORK]
    lines.add(refused(model + " directory", args, os.path.join(WORK, model + "-dir-out"),
                      "pdla: scene %s is not a regular file" % WORK))
check(len(lines) == 1, "directory: the models differ: %r" % lines)

# Two scenes: refused by every model's command (the event command used the
# first and ignored the second).
for model, (first, key, _, _) in MODELS.items():
    path = scene_file(model + "-twice", first)
    for second in (["--scene", path], ["--scene=" + path]):
        refused(model + " scene twice", ["--scene", path] + second,
                os.path.join(WORK, model + "-twice-out"), "pdla: --scene given twice")

# A bad line after the model line goes to that model's command even when
# the command line has options of that model only.
path = scene_file("event-dup-args", "model = event\nseed = 1\nseed = 2\n")
refused("event scene, event options", ["--scene", path, "--particles", "10"],
        os.path.join(WORK, "event-dup-args-out"), "pdla: " + path + ":3: duplicate key 'seed'")
path = scene_file("dlca-dup-args", "model = dlca\nseed = 1\nseed = 2\n")
refused("dlca scene, dlca options", ["--scene", path, "--box", "48"],
        os.path.join(WORK, "dlca-dup-args-out"), "pdla: " + path + ":3: duplicate key 'seed'")

path = scene_file("event-large-args", "model = event\n" + ("#" * 100 + "\n") * 700)
refused("event scene too large, event options", ["--scene", path, "--particles", "10"],
        os.path.join(WORK, "event-large-args-out"), "pdla: " + path + ": too large")

# README, Scenes: a value out of its range is named by line in every model;
# run options or parameters that exclude each other are named by line in the
# DLA command's scenes, while the DLCA and event commands refuse such a
# combination in one line without it (exit 2 all the same).
for model, body, want in (("dla", "eps = 1\n", ":2: eps must be in"), ("dlca", "fill = 2\n", ":2: invalid --fill '2'"),
                          ("event", "stick_p = 2\n", ":2: stick-p must be in [0, 1]"),
                          ("dla", "no-output = yes\ncheckpoint = yes\n", ":3: checkpoints need a run directory")):
    path = scene_file("%s-range-%d" % (model, len(body)), MODELS[model][0] + body)
    refused("%s scene %r" % (model, body), ["--scene", path], os.path.join(WORK, "%s-range-out" % model), "pdla: " + path + want)
for model, body, want in (("dlca", "no-output = yes\ncheckpoint = yes\n", "pdla: checkpoints need a run directory"),
                          ("event", "particles = 10\nseed_radius = 0\n", "pdla: nothing sticks")):
    path = scene_file(model + "-combination", MODELS[model][0] + body)
    refused("%s scene %r" % (model, body), ["--scene", path], os.path.join(WORK, model + "-combination-out"), want)

# Good scenes run, `kT` (spelled as the option) in the event model's.
for model, (first, _, body, quiet) in MODELS.items():
    extra = "kT = 2\n" if model == "event" else ""
    path = scene_file(model + "-ok", first + body + extra)
    out = os.path.join(WORK, model + "-ok-out")
    rc, err = pdla("--scene", path, "--out", out, quiet)
    check(rc == 0 and os.path.exists(os.path.join(out, "cluster.h5")),
          "%s good scene: exit %r, %r" % (model, rc, err[-300:]))
# ... and `kT` is the event model's key only.
path = scene_file("dla-kT", MODELS["dla"][0] + "kT = 2\n")
refused("dla kT", ["--scene", path], os.path.join(WORK, "dla-kT-out"), "pdla: " + path + ":2: unknown key 'kT'")
path = scene_file("event-KT", MODELS["event"][0] + "KT = 2\n")
refused("event KT", ["--scene", path], os.path.join(WORK, "event-KT-out"),
        "pdla: " + path + ":2: unknown key 'KT' (keys are case-sensitive: 'kT')")

if failures:
    print("%d failure(s)" % len(failures))
    sys.exit(1)
shutil.rmtree(WORK, ignore_errors=True)
print("scene-models: all checks passed")
