# SPDX-License-Identifier: MIT
"""Cross-check drcli against an independent decoder written here.

The field layout comes from `drcli list --json` (offset, bit, type); the
bytes are decoded by this script with Python's struct module and compared
with `drcli decode --json` for every leaf of every assembly, over seeded
random images and a few hand-picked ones. REALs must be the shortest
decimal that reads back to the same binary32. Then every decoded image is
encoded again from its FIELD=VALUE pairs and must give back the same bytes
(reserved bits zero).

usage: python3 crosscheck.py DRCLI
"""
import json
import math
import random
import struct
import subprocess
import sys

DRCLI = sys.argv[1]
errors = []


def run(args, data=None):
    p = subprocess.run([DRCLI] + args, input=data, capture_output=True, check=False)
    if p.returncode != 0:
        raise SystemExit("drcli %s failed (%d): %s" % (" ".join(args), p.returncode,
                                                      p.stderr.decode()))
    return p.stdout


def f32(x):
    """x rounded to binary32 as C does (struct refuses what becomes inf)."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


def shortest_digits(x):
    """Fewest significant digits whose %g text reads back to binary32 x."""
    for p in range(1, 10):
        if f32(float("%.*g" % (p, x))) == x:
            return p
    return 9


def significant_digits(text):
    mant = text.lstrip("-").split("e")[0].replace(".", "")
    mant = mant.lstrip("0").rstrip("0")
    return max(len(mant), 1)


def expected(field, img):
    off, kind = field["offset"], field["type"]
    if field["bit"] is not None:
        b = field["bit"]
        return bool(img[off + b // 8] >> (b % 8) & 1)
    if kind.startswith("USINT"):
        return img[off]
    if kind == "DINT":
        return struct.unpack_from("<i", img, off)[0]
    return struct.unpack_from("<f", img, off)[0]


def check_real(path, want, got):
    if math.isnan(want):
        ok = got == "nan"
    elif math.isinf(want):
        ok = got == ("inf" if want > 0 else "-inf")
    else:
        ok = (isinstance(got, str) and got not in ("nan", "inf", "-inf")
              and struct.pack("<f", f32(float(got))) == struct.pack("<f", want)
              and significant_digits(got) == shortest_digits(want))
    if not ok:
        errors.append("%s: expected binary32 %r (shortest %d digits), got %r"
                      % (path, want, shortest_digits(want) if math.isfinite(want) else 0, got))


def used_mask(fields, size):
    """Bytes of the bits that fields own; the rest is reserved."""
    mask = bytearray(size)
    for f in fields:
        if f["bit"] is not None:
            b = f["bit"]
            mask[f["offset"] + b // 8] |= 1 << (b % 8)
        else:
            n = 1 if f["type"].startswith("USINT") else 4
            for i in range(n):
                mask[f["offset"] + i] = 0xFF
    return mask


def check_image(asm, fields, img):
    text = run(["decode", "--json", asm["name"], "-"], bytes(img)).decode()
    # Keep REALs as their text: the shortest form is part of the contract.
    got = json.loads(text, parse_float=str)
    paths = [f["path"] for f in fields]
    if list(got.keys()) != paths:
        errors.append("%s: keys differ from drcli list: %s" % (asm["name"], list(got.keys())[:5]))
        return
    assigns, skip = [], bytearray(len(img))
    for f in fields:
        want, value = expected(f, img), got[f["path"]]
        if f["type"] == "REAL":
            # Whole numbers print as "2.0", which json reads as float text.
            check_real(f["path"], want, value if isinstance(value, str) else str(value))
            if isinstance(value, str) and value in ("nan", "inf", "-inf"):
                for i in range(4):
                    skip[f["offset"] + i] = 1  # a NaN payload is not kept
                if asm["direction"] == "O->T":
                    continue  # and the robot may not be sent one
        elif value != want or type(value) is not type(want):
            errors.append("%s: expected %r, got %r" % (f["path"], want, value))
        if isinstance(value, bool):
            value = "true" if value else "false"
        assigns.append("%s=%s" % (f["path"], value))
    back = run(["encode", asm["name"]] + assigns)
    mask = used_mask(fields, len(img))
    for i, (a, b) in enumerate(zip(back, img)):
        if not skip[i] and a != b & mask[i]:
            errors.append("%s: re-encoded byte %d is %02x, expected %02x"
                          % (asm["name"], i, a, b & mask[i]))
            break
    if len(back) != len(img):
        errors.append("%s: re-encoded %d bytes" % (asm["name"], len(back)))


def main():
    layout = json.loads(run(["list", "--json"]))
    rng = random.Random(20240611)
    special = [0.1, 31.5, 1e-7, 3.4028235e38, -0.0, 1 / 3, 16777217.0, 1e-45,
               1.17549435e-38, 123456789.0, 2.5, -90.0]
    for asm in layout["assemblies"]:
        fields = [f for f in layout["fields"] if f["assembly"] == asm["name"]]
        size = asm["size"]
        images = [bytearray(size), bytearray(b"\xff" * size)]
        for _ in range(20):
            images.append(bytearray(rng.getrandbits(8) for _ in range(size)))
        # REALs drawn from finite floats of every magnitude, and hand-picked.
        for _ in range(5):
            img = bytearray(rng.getrandbits(8) for _ in range(size))
            for f in fields:
                if f["type"] == "REAL":
                    x = rng.choice(special + [rng.uniform(-1e3, 1e3),
                                              rng.uniform(-1, 1) * 10 ** rng.randint(-40, 38)])
                    struct.pack_into("<f", img, f["offset"], f32(x))
            images.append(img)
        for img in images:
            check_image(asm, fields, img)
    for e in errors[:30]:
        print(e)
    print("crosscheck: %d assemblies, %d errors" % (len(layout["assemblies"]), len(errors)))
    return 1 if errors else 0


sys.exit(main())
