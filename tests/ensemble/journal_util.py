"""journal_util.py - read and forge ensemble journals (clusters.journal) in
tests: the header (PDLAENS1, byte-order mark, text, FNV-1a) and the records
that follow, each starting with its magic and its u64 length n: cluster
records PDLAREC2 (then the u64 fingerprint of the growth parameters, n
bytes and an 8-byte checksum of length, fingerprint and bytes), format 1's
cluster records PDLAREC1 and build records PDLABLD1 (n bytes and an 8-byte
checksum of length and bytes; native order)."""
import struct


def fnv1a(data, h=0xcbf29ce484222325):
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def head_len(rec):
    """Bytes before the payload: 24 for a record with a fingerprint, else 16."""
    return 24 if rec[:8] == b"PDLAREC2" else 16


def payload(rec):
    """A record's payload (bytes) from its whole bytes."""
    return rec[head_len(rec):-8]


def record_index(rec):
    """The cluster index of a cluster record (PDLAREC1 or PDLAREC2)."""
    return struct.unpack_from("=Q", rec, head_len(rec))[0]


def fingerprint(rec):
    """The fingerprint a PDLAREC2 record carries."""
    return struct.unpack_from("=Q", rec, 16)[0]


def frame(body, fp=None):
    """A cluster record of payload body: with fingerprint fp (PDLAREC2), or
    as format 1 wrote it (PDLAREC1) when fp is None."""
    n = struct.pack("=Q", len(body))
    if fp is None:
        return b"PDLAREC1" + n + body + struct.pack("=Q", fnv1a(body, fnv1a(n)))
    f = struct.pack("=Q", fp)
    return b"PDLAREC2" + n + f + body + struct.pack("=Q", fnv1a(body, fnv1a(f, fnv1a(n))))


def as_format1(rec):
    """A record with a fingerprint written again as format 1 wrote it."""
    return frame(payload(rec))


def read_journal(path):
    """(header text, [record bytes]) of a journal."""
    raw = open(path, "rb").read()
    assert raw[:8] == b"PDLAENS1"
    _, tl = struct.unpack("=II", raw[8:16])
    text = raw[16:16 + tl].decode()
    off, recs = 24 + tl, []
    while off < len(raw):
        (n,) = struct.unpack("=Q", raw[off + 8:off + 16])
        end = off + head_len(raw[off:off + 8]) + n + 8
        recs.append(raw[off:end])
        off = end
    return text, recs


def write_journal(path, text, recs):
    """A journal with header text and the given records, byte for byte."""
    t = text.encode()
    head = b"PDLAENS1" + struct.pack("=II", 0x01020304, len(t)) + t + struct.pack("=Q", fnv1a(t))
    with open(path, "wb") as fh:
        fh.write(head + b"".join(recs))
