#!/usr/bin/env python3
"""Writes the fuzzers' seed inputs into test/fuzz/corpus/ (valid messages of
each kind, from the protocols' documents: SCIP 2.0, Dynamixel 1.0 and 2.0)."""
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


def put(name, seed, data):
    d = os.path.join(HERE, "corpus", name)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, seed), "wb") as f:
        f.write(data)


# ---- SCIP 2.0: sums are the low 6 bits of the byte sum + 0x30
def ssum(s):
    return chr((sum(s.encode()) & 0x3F) + 0x30)


def enc(v, n):
    return "".join(chr(((v >> (6 * (n - 1 - i))) & 0x3F) + 0x30) for i in range(n))


def data_lines(data):
    return "".join(data[i:i + 64] + ssum(data[i:i + 64]) + "\n" for i in range(0, len(data), 64))


def scan_reply(cmd, status, ranges, stamp, intensity=False):
    body = enc(stamp, 4) + ssum(enc(stamp, 4)) + "\n"
    vals = "".join(enc(r, 3) + (enc(1000 + r % 500, 3) if intensity else "") for r in ranges)
    return cmd + "\n" + status + ssum(status) + "\n" + body + data_lines(vals) + "\n"


ranges = [1000 + int(300 * math.sin(i / 5.0)) for i in range(41)]
put("fuzz_scip", "md", scan_reply("MD0000004001000", "99", ranges, 123456).encode())
put("fuzz_scip", "gd", scan_reply("GD0000004000", "00", ranges, 777).encode())
put("fuzz_scip", "me", scan_reply("ME0000004001001", "99", ranges, 5, intensity=True).encode())
put("fuzz_scip", "md_ack", b"MD0000108001000\n00P\n\n")
vv = ["VEND:Hokuyo Automatic Co.,Ltd.;", "PROD:SOKUIKI Sensor UTM-30LX-EW;", "FIRM:1.1.1;", "SERI:H0000001;"]
put("fuzz_scip", "vv", ("VV\n00P\n" + "".join(l + ssum(l[:-1]) + "\n" for l in vv) + "\n").encode())
put("fuzz_scip", "error", b"MD0000108001000\n0C1\n\n")

# ---- Dynamixel
def crc16(data):
    crc = 0
    for b in data:
        crc ^= b << 8
        for _ in range(8):
            crc = ((crc << 1) ^ 0x8005) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
    return crc


def v1(id_, instr_or_err, params):
    body = [id_, len(params) + 2, instr_or_err] + params
    return bytes([0xFF, 0xFF] + body + [(~sum(body)) & 0xFF])


def v2(id_, instr, params, err=None):
    p = ([err] if err is not None else []) + params
    ln = len(p) + 3
    pkt = [0xFF, 0xFF, 0xFD, 0x00, id_, ln & 0xFF, ln >> 8, instr] + p
    c = crc16(pkt)
    return bytes(pkt + [c & 0xFF, c >> 8])


put("fuzz_dynamixel", "v1_status", v1(1, 0, [0x00, 0x08]))
put("fuzz_dynamixel", "v1_read", v1(1, 2, [36, 2]))
put("fuzz_dynamixel", "v2_ping_status", v2(1, 0x55, [0x06, 0x04, 0x26], err=0))
put("fuzz_dynamixel", "v2_read_status", v2(1, 0x55, [0x00, 0x08, 0x00, 0x00], err=0))
put("fuzz_dynamixel", "v2_ping", v2(1, 0x01, []))
put("fuzz_dynamixel", "garbage_then_v2", b"\x00\xff\x13" + v2(2, 0x55, [1, 2, 3], err=0x80))

# ---- split: mode, zeta, d_min, jump_min, jump_ratio, min_points, merge, angle_min, increment, range limits, flag
hdr = struct.pack("<Bffffbbffffb", 0, 0.01, 0.03, 0.05, 0.05, 5, 1, -2.356, 0.004363, 0.023, 60.0, 0)
room = [2.0 / max(0.2, abs(math.cos(-2.356 + 0.004363 * i))) for i in range(1081)]
put("fuzz_split", "room", hdr + struct.pack("<%df" % len(room), *room))
holes = [float("nan") if i % 17 == 0 else (float("inf") if i % 29 == 0 else 3.0) for i in range(200)]
put("fuzz_split", "holes", hdr + struct.pack("<%df" % len(holes), *holes))

# ---- grouping: a byte pattern that walks through joints and lines
put("fuzz_grouping", "walk", bytes((i * 37 + 11) % 256 for i in range(2048)))
put("fuzz_grouping", "joints_then_lines", bytes([0, 0, 5, 0] * 200 + [2, 0, 25, 0, 40, 0] * 100))
