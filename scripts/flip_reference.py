#!/usr/bin/env python3
"""Makes the FLIP test pairs of tests/data/flip/ and prints their mean FLIP from NVIDIA's own
implementation (PyPI `flip-evaluator`, `pip install flip-evaluator numpy`), the values
tests/compare.rs checks hadou's FLIP (the nv-flip crate) against. 67 pixels per degree, LDR."""
import struct
import sys
import zlib
from pathlib import Path

import flip_evaluator as flip
import numpy as np

W = H = 48


def png(path, img):
    raw = b"".join(b"\0" + img[y].astype(np.uint8).tobytes() for y in range(img.shape[0]))
    def chunk(kind, data):
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)
    header = struct.pack(">IIBBBBB", img.shape[1], img.shape[0], 8, 2, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def lcg(n, seed):
    out, s = [], seed
    for _ in range(n):
        s = (s * 6364136223846793005 + 1442695040888963407) % 2**64
        out.append(s >> 33)
    return np.array(out, dtype=np.int64)


def pairs():
    y, x = np.mgrid[0:H, 0:W]
    grad = np.stack([x * 255 // (W - 1), y * 255 // (H - 1), (x + y) * 255 // (W + H - 2)], -1)
    noise = (lcg(W * H * 3, 7) % 13 - 6).reshape(H, W, 3)
    yield "gradient", grad, np.clip(grad + noise, 0, 255)
    checker = (((x // 4) + (y // 4)) % 2)[..., None] * np.array([220, 180, 40]) + 20
    yield "shift", checker, np.roll(checker, 1, axis=1)
    halves = np.where((x < W // 2)[..., None], np.array([200, 30, 30]), np.array([30, 30, 200]))
    yield "colors", halves, np.where((x < W // 2)[..., None], np.array([185, 45, 30]), np.array([30, 60, 190]))
    grey = np.full((H, W, 3), 128)
    one = grey.copy()
    one[20, 30] = 255
    yield "onepixel", grey, one


def main():
    out = Path(sys.argv[1] if len(sys.argv) > 1 else "tests/data/flip")
    out.mkdir(parents=True, exist_ok=True)
    for name, ref, test in pairs():
        png(out / f"{name}_ref.png", ref)
        png(out / f"{name}_test.png", test)
        _, mean, _ = flip.evaluate(ref / 255.0, test / 255.0, "LDR", parameters={"ppd": 67.0}, applyMagma=False)
        print(f"{name} {mean:.6f}")


if __name__ == "__main__":
    main()
