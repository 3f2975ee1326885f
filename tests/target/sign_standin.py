#!/usr/bin/env python3
# TEMPORARY stand-in for `wdrctl fw sign` until it is merged (openssl CLI + struct); remove then.
# usage: sign_standin.py KEY.pem APP.bin OUT.img VERSION COUNTER [BOARD]
import hashlib, os, struct, subprocess, sys, tempfile


def raw_sig(der):
    i = 2 if der[1] < 0x80 else 3
    out = b""
    for _ in range(2):
        n = der[i + 1]
        out += der[i + 2:i + 2 + n].lstrip(b"\0").rjust(32, b"\0")
        i += 2 + n
    return out


key, app, outp, ver, sc = sys.argv[1:6]
board = (sys.argv[6] if len(sys.argv) > 6 else "mps2-an500").encode()
v = [int(x) for x in ver.split(".")]
body = open(app, "rb").read()
body += b"\0" * (-len(body) % 16)
dev = b"NOT-FOR-PRODUCTION" in key.encode()
hdr = struct.pack("<IHBBIIBBHIII", 0x474D4957, 64, 1, 0, len(body), 0x20000, v[0], v[1], v[2], 0, int(sc),
                  1 | (2 if dev else 0)) + board.ljust(16, b"\0") + b"\0" * 16
with tempfile.TemporaryDirectory() as t:
    open(t + "/m", "wb").write(hdr + body)
    der = subprocess.run(["openssl", "dgst", "-sha256", "-sign", key, t + "/m"], capture_output=True, check=True).stdout
    point = subprocess.run(["openssl", "pkey", "-in", key, "-pubout", "-outform", "DER"], capture_output=True,
                           check=True).stdout[-65:]
trl = struct.pack("<IHH", 0x4C544957, 136, 1) + hashlib.sha256(hdr + body).digest() + \
    hashlib.sha256(point).digest() + raw_sig(der)
open(outp, "wb").write(hdr + body + trl)
