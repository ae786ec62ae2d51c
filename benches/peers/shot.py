"""The bunny shot of benches/peers/bunny/bunny.toml, read once for every peer.

`python3 shot.py embree-args` prints the camera/light/plane options of the Embree harness;
`python3 shot.py compare A.png B.png` prints how many pixels of two images differ. The other
peers (embreex_bunny.py, mitsuba_shot.py) import `load()` and `camera_rays()`.
"""

import math
import sys
import tomllib
from pathlib import Path

SCENE = Path(__file__).resolve().parent / "bunny" / "bunny.toml"


def load(path=SCENE):
    """Camera, light, plane and materials of the raylab scene, as plain numbers."""
    with open(path, "rb") as f:
        s = tomllib.load(f)
    cam = s["camera"]
    objs = {o["name"]: o for o in s["object"]}
    light = next(l for l in s["light"] if l["type"] == "directional")
    ambient = next(l for l in s["light"] if l["type"] == "ambient")
    return {
        "width": s["render"]["width"],
        "height": s["render"]["height"],
        "position": [float(v) for v in cam["position"]],
        "look_at": [float(v) for v in cam["look_at"]],
        "fov": float(cam.get("fov", 45)),
        "light_dir": [float(v) for v in light["direction"]],
        "light": float(light["color"]),
        "ambient": float(ambient["color"]) * float(ambient["ka"]),
        "plane_y": float(objs["ground"]["point"][1]),
        "kd_mesh": float(objs["bunny"]["material"]["kd"]),
        "kd_plane": float(objs["ground"]["material"]["kd"]),
        "mesh": objs["bunny"]["file"],
    }


def _norm(v):
    n = math.sqrt(sum(x * x for x in v))
    return [x / n for x in v]


def camera_rays(shot):
    """Unit directions (H·W × 3, float64, row-major, y down) of raylab's look-at camera
    (src/camera.rs): the ray through each pixel centre."""
    import numpy as np

    W, H = shot["width"], shot["height"]
    pos = np.array(shot["position"])
    target = np.array(shot["look_at"])
    dist = np.linalg.norm(target - pos)
    to = (target - pos) / dist
    up = np.array([0.0, 1.0, 0.0])
    up = up - up.dot(to) * to
    up /= np.linalg.norm(up)
    right = np.cross(to, up)
    sh = 2.0 * dist * math.tan(math.radians(shot["fov"]) * 0.5)
    sw = sh * W / H
    xs = (np.arange(W) + 0.5 - W / 2.0) * (sw / W)
    ys = (np.arange(H) + 0.5 - H / 2.0) * (sh / H)
    p = pos + dist * to + xs[None, :, None] * right - ys[:, None, None] * up
    d = (p - pos).reshape(-1, 3)
    return d / np.linalg.norm(d, axis=1)[:, None]


def embree_args(shot):
    c = shot["position"] + shot["look_at"] + [shot["fov"]]
    return (
        ["--camera"] + [repr(v) for v in c]
        + ["--light"] + [repr(v) for v in shot["light_dir"]]
        + ["--plane", repr(shot["plane_y"]), "--width", str(shot["width"]), "--height", str(shot["height"])]
    )


def compare(a, b):
    """Pixels of two 8-bit images that differ at all, by more than 2 levels, and the largest
    difference; and how many are not background (black) in each."""
    import numpy as np
    from PIL import Image

    x = np.asarray(Image.open(a).convert("RGB")).astype(int)
    y = np.asarray(Image.open(b).convert("RGB")).astype(int)
    if x.shape != y.shape:
        return f"sizes differ: {x.shape} vs {y.shape}"
    d = np.abs(x - y).max(axis=2)
    return (
        f"pixels differing: {(d > 0).sum()} (by > 2 levels: {(d > 2).sum()}, largest {d.max()}); "
        f"non-background pixels: {(x.max(axis=2) > 0).sum()} vs {(y.max(axis=2) > 0).sum()}"
    )


if __name__ == "__main__":
    if sys.argv[1:2] == ["embree-args"]:
        print(" ".join(embree_args(load())))
    elif sys.argv[1:2] == ["compare"] and len(sys.argv) == 4:
        print(compare(sys.argv[2], sys.argv[3]))
    elif sys.argv[1:2] == ["ppm-to-png"] and len(sys.argv) == 4:
        from PIL import Image

        Image.open(sys.argv[2]).save(sys.argv[3])
    else:
        sys.exit("usage: shot.py embree-args | compare A B | ppm-to-png IN.ppm OUT.png")
