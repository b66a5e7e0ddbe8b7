"""journal_util.py - read and forge ensemble journals (clusters.journal) in
tests: the header (PDLAENS1, byte-order mark, text, FNV-1a) and the records
that follow, each starting with its magic (PDLAREC1 clusters, PDLABLD1
builds), its u64 length n, n bytes and an 8-byte checksum (native order)."""
import struct


def fnv1a(data):
    h = 0xcbf29ce484222325
    for b in data:
        h = ((h ^ b) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h


def read_journal(path):
    """(header text, [record bytes]) of a journal."""
    raw = open(path, "rb").read()
    assert raw[:8] == b"PDLAENS1"
    _, tl = struct.unpack("=II", raw[8:16])
    text = raw[16:16 + tl].decode()
    off, recs = 24 + tl, []
    while off < len(raw):
        (n,) = struct.unpack("=Q", raw[off + 8:off + 16])
        recs.append(raw[off:off + 24 + n])
        off += 24 + n
    return text, recs


def write_journal(path, text, recs):
    """A journal with header text and the given records, byte for byte."""
    t = text.encode()
    head = b"PDLAENS1" + struct.pack("=II", 0x01020304, len(t)) + t + struct.pack("=Q", fnv1a(t))
    with open(path, "wb") as fh:
        fh.write(head + b"".join(recs))
