#!/usr/bin/env python3
"""test_event_forged.py PDLA - event checkpoints whose pending events are
forged (h5py) but in range, through `pdla --model event --resume`.

The loader checked that a pending event's partner index is in range and its
time at or after the checkpoint's, nothing more; the loop acts on a live
event (a wall, or a partner whose collision counter is the one recorded)
without looking again. So a checkpoint whose pending event named the
particle itself (a collision at distance 0: NaN velocities), a particle or
the seed across the box (hit, or stuck to, from afar), a time at which the
pair does not touch or recedes, a partner counter never reached, or a wall
the particle does not meet was resumed. Each forged copy must now be refused
with one line naming the fault, exit 2, within a time limit; the untouched
copies (a box with walls and a sticking seed, a periodic gas) must resume.
The same for forged cell crossings (t_cell, cell_what).
"""
import os
import shutil
import subprocess
import sys
import tempfile

import h5py
import numpy as np

PDLA = sys.argv[1]
TIME_LIMIT = 60
fails = 0


def check(cond, msg):
    global fails
    if not cond:
        print("FAIL: " + msg)
        fails += 1


def run(args):
    """(exit status, stderr lines), or (None, []) past TIME_LIMIT."""
    try:
        p = subprocess.run([PDLA] + args, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           timeout=TIME_LIMIT)
    except subprocess.TimeoutExpired:
        return None, []
    err = p.stderr.decode("utf-8", "replace").rstrip("\n")
    return p.returncode, err.split("\n") if err else []


work = tempfile.mkdtemp()


class State:
    """The checkpoint's /state as numpy arrays (copies)."""

    def __init__(self, path):
        with h5py.File(path, "r") as f:
            self.dim = int(f.attrs["dim"])
            self.n = int(f.attrs["particles"])
            g = f["state"]
            self.a = {k: g[k][()].copy() for k in ("ps", "count", "stuck", "t_pair", "t_cell", "partner",
                                                   "pcount", "kind", "cell_what", "reals")}
            self.now = float(g["reals"][0])
        self.ps = self.a["ps"].reshape(-1, 2 * self.dim + 2)

    def pos(self, i, t):
        D, p = self.dim, self.ps[i]
        return p[:D] + p[D:2 * D] * (t - p[2 * D])

    def sep(self, i, j, t):
        """r_j - r_i at t (a box with walls), v_j - v_i."""
        D = self.dim
        return self.pos(j, t) - self.pos(i, t), self.ps[j][D:2 * D] - self.ps[i][D:2 * D]

    def live_pairs(self):
        a = self.a
        out = []
        for i in range(self.n):
            j = int(a["partner"][i])
            if (not a["stuck"][i] and a["kind"][i] == 1 and j < len(self.ps) and j != i
                    and a["pcount"][i] == a["count"][j] and np.isfinite(a["t_pair"][i])):
                out.append((i, j))
        return out


def base(tag, args):
    d = os.path.join(work, tag)
    rc, lines = run(args + ["--out", d, "--checkpoint", "--quiet"])
    if rc != 0:
        sys.exit("base run %s failed: %r" % (tag, lines))
    return os.path.join(d, "checkpoint.h5")


def forged(src, tag, fn):
    """A run directory holding only a copy of src with fn(state arrays)
    applied (no checkpoint.prev.h5 to fall back on)."""
    d = os.path.join(work, "f-" + tag)
    os.makedirs(d)
    path = os.path.join(d, "checkpoint.h5")
    shutil.copy(src, path)
    if fn is not None:
        st = State(path)
        fn(st.a)
        with h5py.File(path, "r+") as f:
            for k, v in st.a.items():
                if not np.array_equal(f["state/" + k][()], v, equal_nan=True):
                    del f["state/" + k]
                    f["state/" + k] = v
    return d


def expect(tag, d, t_max, want):
    """want None: resumed (exit 0); else refused, exit 2, one line holding want."""
    rc, lines = run(["--model", "event", "--resume", d, "--t-max", str(t_max), "--quiet"])
    if rc is None:
        check(False, "%s: did not end within %d s" % (tag, TIME_LIMIT))
        return
    if want is None:
        check(rc == 0, "%s: exit %d, want 0 (resumed): %r" % (tag, rc, lines[:3]))
        return
    check(rc == 2, "%s: exit %d, want 2 (refused): %r" % (tag, rc, lines[:3]))
    check(len(lines) == 1, "%s: %d lines on stderr, want 1: %r" % (tag, len(lines), lines[:3]))
    check(bool(lines) and want in lines[0], "%s: the line does not say %r: %r" % (tag, want, lines[:1]))


def setv(name, i, v):
    def fn(a):
        a[name][i] = v
    return fn


def setm(changes):
    def fn(a):
        for name, i, v in changes:
            a[name][i] = v
    return fn


# ---- a box with walls, a seed that sticks ---------------------------------
WA = base("walls", ["--model", "event", "--dim", "2", "--particles", "300", "--packing", "0.1", "--seed-radius",
                    "1", "--t-max", "2", "--series-dt", "0.5", "--seed", "3"])
S = State(WA)
n, D = S.n, S.dim
pairs = S.live_pairs()
free_pairs = [(i, j) for i, j in pairs if j < n and not S.a["stuck"][j]]
check(len(free_pairs) >= 2, "walls: only %d live pair events between free particles" % len(free_pairs))
i, j = free_pairs[0]
tp = float(S.a["t_pair"][i])
r, v = S.sep(i, j, tp)
sig = S.ps[i][2 * D + 1] + S.ps[j][2 * D + 1]
check(abs(np.linalg.norm(r) - sig) < 1e-9 * sig and r @ v < 0, "walls: the live pair %d-%d does not touch" % (i, j))
expect("walls clean", forged(WA, "walls-clean", None), 3, None)

NOT_MEET = "do not meet then"
# the particle itself as its partner (its own counter): collide(i, i)
expect("self partner", forged(WA, "self", setm([("partner", i, i), ("pcount", i, S.a["count"][i])])), 3,
       "names its own particle")
# a counter other than the partner's is a stale event, predicted again when
# it comes up: harmless, and "ahead" is no fault (32-bit counters wrap: a
# valid checkpoint holds one after a partner's 2^32-th event)
expect("counter ahead", forged(WA, "ahead", setv("pcount", i, S.a["count"][j] + 1)), 3, None)
expect("counter wrapped", forged(WA, "wrapped", setv("pcount", i, (int(S.a["count"][j]) - 5) % 2**32)), 3, None)
# a free particle far from i at the event's time, its counter matching
far = [k for k in range(n) if k not in (i, j) and not S.a["stuck"][k]
       and np.linalg.norm(S.sep(i, k, tp)[0]) > 3 * sig]
expect("far partner", forged(WA, "far", setm([("partner", i, far[0]), ("pcount", i, S.a["count"][far[0]])])), 3,
       NOT_MEET)
# the seed (index n, stuck, counter 0) as the partner, far from i
seed_far = [(a, b) for a, b in free_pairs if np.linalg.norm(S.sep(a, n, float(S.a["t_pair"][a]))[0]) > 5]
a0 = seed_far[0][0]
expect("far seed", forged(WA, "seed", setm([("partner", a0, n), ("pcount", a0, 0)])), 3, NOT_MEET)
# the right pair at another time: half way there, or when it would part
expect("time halved", forged(WA, "half", setv("t_pair", i, S.now + 0.5 * (tp - S.now))), 3, NOT_MEET)
r0, v0 = S.sep(i, j, tp)
# from contact at tp: |r0 + v0 u| = sig again at u = -2 r0.v0 / v0.v0 (receding then)
t_out = tp - 2 * float(r0 @ v0) / float(v0 @ v0)
expect("receding", forged(WA, "receding", setv("t_pair", i, t_out)), 3, NOT_MEET)
# before the particle's own time (refused before this test too)
expect("before now", forged(WA, "before", setv("t_pair", i, S.ps[i][2 * D] - 1)), 3, "before the checkpoint's time")
# walls: the time moved, the other wall, no event at all for a moving particle
walls = [k for k in range(n) if not S.a["stuck"][k] and S.a["kind"][k] == 2]
w = walls[0]
expect("wall time", forged(WA, "wall-time", setv("t_pair", w, S.a["t_pair"][w] + 0.5)), 3, "does not meet that wall")
expect("wall side", forged(WA, "wall-side", setv("partner", w, S.a["partner"][w] ^ 1)), 3, "does not meet that wall")
expect("no event", forged(WA, "no-event", setm([("kind", w, 0), ("t_pair", w, np.inf)])), 3,
       "without a pending event")

# ---- a periodic gas: the image nearest at the event's time ----------------
PA = base("periodic", ["--model", "event", "--dim", "3", "--particles", "400", "--packing", "0.2", "--box-walls",
                       "periodic", "--seed-radius", "0", "--t-max", "1", "--seed", "5"])
P = State(PA)
ppairs = P.live_pairs()
check(len(ppairs) >= 1, "periodic: no live pair event")
expect("periodic clean", forged(PA, "periodic-clean", None), 2, None)
pi_, pj_ = ppairs[0]
expect("periodic time", forged(PA, "periodic-time", setv("t_pair", pi_, P.a["t_pair"][pi_] + 0.5)), 2, NOT_MEET)

# ---- a pending event missing or late --------------------------------------
# Only the events present were checked: with every free particle's pair
# event deleted (no event is valid in a periodic box: a particle at rest)
# the run resumed and particles passed 0.64 of a diameter into each other.
# Now no two neighbours may come closer than contact, moving straight,
# before either's pending event.
PASS = "into each other before either's pending event"
P_free = np.nonzero(P.a["stuck"][:P.n] == 0)[0]
expect("pair events deleted", forged(PA, "drop-all", setm([("kind", P_free, 0), ("t_pair", P_free, np.inf)])), 2,
       PASS)
# one pair's events only: both particles of a live pair that hold each other
mutual = [(a, b) for a, b in ppairs if b < P.n and P.a["partner"][b] == a and P.a["kind"][b] == 1]
check(len(mutual) >= 1, "periodic: no pair holding each other's event")
if mutual:
    a, b = mutual[0]
    expect("one pair's events deleted", forged(PA, "drop-one", setm([("kind", [a, b], 0), ("t_pair", [a, b], np.inf)])),
           2, PASS)
    # moved past the contact (stale: the counter ahead, so no live event to check)
    late = float(P.a["t_pair"][a]) + 0.5
    expect("one pair's events late", forged(PA, "late-one", setm([("t_pair", [a, b], late),
                                                                ("pcount", [a, b], P.a["count"][[b, a]] + 1)])), 2, PASS)
# between walls, a wall event turned into a stale pair event after the wall
wl = walls[1]
expect("pair event after the wall", forged(WA, "after-wall", setm([("kind", wl, 1), ("partner", wl, (wl + 1) % n),
                                                                   ("pcount", wl, S.a["count"][(wl + 1) % n] + 1),
                                                                   ("t_pair", wl, S.a["t_pair"][wl] + 0.5)])), 3,
       "passed a wall")

# ---- speeds beyond any start and an overlap above 1 ------------------------
# A particle made 1e200 times faster (its crossing re-timed) loaded: the run
# wrote kinetic_energy_free Infinity or, without a stop, never ended; a gas
# made 30 times faster (the same paths, events re-timed) ran on as well.
# The kinetic energy, free and stuck, can be no more than the start's (at
# most 36.8 d N kT).
def faster(st, k, f):
    def fn(a):
        D = st.dim
        ps = a["ps"].reshape(-1, 2 * D + 2)
        ps[k, :D] += ps[k, D:2 * D] * (st.now - ps[k, 2 * D])
        ps[k, 2 * D] = st.now
        ps[k, D:2 * D] *= f
        a["kind"][k], a["t_pair"][k] = 0, np.inf
        a["t_cell"][k] = st.now + (a["t_cell"][k] - st.now) / f
    return fn


def hotter(st, f):
    """Every free particle f times faster from now on, its events re-timed:
    the same paths, a gas f^2 hotter than its kT could start."""
    def fn(a):
        D = st.dim
        ps = a["ps"].reshape(-1, 2 * D + 2)
        for k in np.nonzero(a["stuck"][:st.n] == 0)[0]:
            ps[k, :D] += ps[k, D:2 * D] * (st.now - ps[k, 2 * D])
            ps[k, 2 * D] = st.now
            ps[k, D:2 * D] *= f
            for name in ("t_pair", "t_cell"):
                if np.isfinite(a[name][k]):
                    a[name][k] = st.now + (a[name][k] - st.now) / f
    return fn


expect("speed x 1e200", forged(PA, "fast", faster(P, int(P_free[0]), 1e200)), 2, "kinetic energy")
expect("gas 900 times hotter", forged(PA, "hot", hotter(P, 30.0)), 2, "kinetic energy")
expect("gas 4 times hotter", forged(PA, "warm", hotter(P, 2.0)), 2, None)  # within the bound: a valid state
# /results max_overlap_seen: an overlap / contact distance is at most 1
expect("max_overlap 7", forged(PA, "max-overlap", setv("reals", 5, 7.0)), 2, "overlap above 1")

# ---- cell crossings: when a particle reaches that face of its cell ---------
# The loop moves a particle to the next cell only at that event: a forged
# t_cell of 1e159 for every particle (fuzz_mut_event) resumed, ran with no
# particle ever leaving its first cell, and wrote a checkpoint its own
# loader refused ("a particle outside its cell").
CROSS_LEFT = "after the particle has left its cell"
CROSS_FACE = "not at that face then"
movers = [k for k in range(n) if not S.a["stuck"][k] and S.a["cell_what"][k] >= 0 and np.isfinite(S.a["t_cell"][k])]
c0 = movers[0]
expect("t_cell all late", forged(WA, "tcell-all", lambda a: a["t_cell"].__setitem__(a["cell_what"] >= 0, 1e159)),
       3, CROSS_LEFT)
expect("t_cell early", forged(WA, "tcell-early", setv("t_cell", c0, S.now + 0.5 * (S.a["t_cell"][c0] - S.now))), 3,
       CROSS_FACE)
expect("t_cell face", forged(WA, "tcell-face", setv("cell_what", c0, S.a["cell_what"][c0] ^ 1)), 3, CROSS_FACE)
# a crossing through a wall: the step would wrap the particle by L
# a particle flying up on x within a diameter (<= a cell) of the upper x
# wall: its cell is the top one on x
with h5py.File(os.path.join(os.path.dirname(WA), "cluster.h5"), "r") as f:
    side = float(f["results"].attrs["box_side"])
wall_x = [k for k in range(n) if not S.a["stuck"][k] and S.ps[k][D] > 0 and S.pos(k, S.now)[0] > side - 1]
if wall_x:
    k = wall_x[0]
    expect("crossing a wall", forged(WA, "tcell-wall", setm([("cell_what", k, 1), ("t_cell", k, S.now)])), 3,
           "through a wall of the box")
else:
    check(False, "walls: no particle flying into the upper x wall")
pm = [k for k in range(P.n) if not P.a["stuck"][k] and P.a["cell_what"][k] >= 0][0]
# a wall event in a periodic box
expect("periodic wall", forged(PA, "periodic-wall", setm([("kind", pm, 2), ("partner", pm, 0)])), 2, "names no wall")
expect("no crossing", forged(PA, "no-crossing", setm([("cell_what", pm, -1), ("t_cell", pm, np.inf)])), 2,
       "without its next cell crossing")

# ---- valid dilute runs at a late clock: the round-off of a position grows
# with |v| t; fixed 1e-6 tolerances refused these (a wall met 3e-5 radii off
# at t = 1e10 in a gas of packing 1e-12)
for tag, walls in (("dilute walls", "elastic"), ("dilute periodic", "periodic")):
    d = os.path.dirname(base(tag.replace(" ", "-"), ["--model", "event", "--particles", "20", "--seed-radius", "0",
                                                     "--packing", "1e-12", "--t-max", "1e10", "--box-walls", walls]))
    expect(tag, d, 2e10, None)

shutil.rmtree(work, ignore_errors=True)
print("%d failures" % fails)
sys.exit(1 if fails else 0)
