#!/usr/bin/env python3
"""Writes sky.hdr, the small procedural HDR sky of raylab's bundled environment scenes (CC0;
Python 3 only, no packages). Run: python3 make_sky.py

A 128 x 64 equirectangular (latitude-longitude) image in Radiance RGBE (.hdr, run-length
encoded scanlines): top row straight up, bottom row straight down, centre column the direction
-z (raylab's `environment` convention). Linear radiance:

- the sky: a gradient from a pale, bright horizon to a deep blue zenith, brighter toward the sun;
- the sun: a disc of radius 4 degrees at azimuth 35 degrees right of the centre, elevation 35
  degrees, of radiance about 300 (the sky's irradiance on a level surface is about 1.9,
  the sun's about 2.5: shadows are clear and soft);
- the ground: a dim warm grey, darker toward the nadir.
"""
import math

W, H = 128, 64
SUN_AZIMUTH, SUN_ELEVATION, SUN_RADIUS = math.radians(35), math.radians(35), math.radians(4)
SUN = (320.0, 290.0, 240.0)


def direction(u, v):
    """World direction of image coordinates (u right, v down), as raylab maps them."""
    phi, theta = (u - 0.5) * 2 * math.pi, v * math.pi
    return (math.sin(theta) * math.sin(phi), math.cos(theta), -math.sin(theta) * math.cos(phi))


def sun_dir():
    ce = math.cos(SUN_ELEVATION)
    return (ce * math.sin(SUN_AZIMUTH), math.sin(SUN_ELEVATION), -ce * math.cos(SUN_AZIMUTH))


def radiance(d):
    s = sun_dir()
    cos_sun = sum(a * b for a, b in zip(d, s))
    if cos_sun > math.cos(SUN_RADIUS):
        return SUN
    y = d[1]
    if y < 0:
        k = min(1.0, -y * 3)
        return tuple(c * (1 - 0.5 * k) for c in (0.32, 0.28, 0.24))
    k = y ** 0.45
    base = (0.95 - 0.75 * k, 1.0 - 0.55 * k, 1.15 - 0.2 * k)
    glow = 0.6 * max(0.0, cos_sun) ** 8
    return tuple(c + glow * g for c, g in zip(base, (1.0, 0.85, 0.6)))


def rgbe(c):
    m = max(c)
    if m < 1e-32:
        return (0, 0, 0, 0)
    mant, e = math.frexp(m)
    scale = mant * 256.0 / m
    return tuple(min(255, int(x * scale)) for x in c) + (e + 128,)


def scanline(pixels):
    """A new-style RLE scanline: each channel as literal runs of at most 128 bytes."""
    out = bytearray([2, 2, W >> 8, W & 255])
    for ch in range(4):
        data = [p[ch] for p in pixels]
        for i in range(0, W, 128):
            chunk = data[i:i + 128]
            out.append(len(chunk))
            out.extend(chunk)
    return bytes(out)


def main():
    with open("sky.hdr", "wb") as f:
        f.write(b"#?RADIANCE\n# raylab scenes/assets/make_sky.py\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(b"-Y %d +X %d\n" % (H, W))
        for y in range(H):
            row = []
            for x in range(W):
                # The mean of 4 x 4 points across the pixel: the sun's rim is antialiased.
                acc = [0.0, 0.0, 0.0]
                for j in range(4):
                    for i in range(4):
                        c = radiance(direction((x + (i + 0.5) / 4) / W, (y + (j + 0.5) / 4) / H))
                        acc = [a + b / 16 for a, b in zip(acc, c)]
                row.append(rgbe(acc))
            f.write(scanline(row))


if __name__ == "__main__":
    main()
