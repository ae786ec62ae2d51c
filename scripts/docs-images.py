#!/usr/bin/env python3
"""Makes every image in docs/ again, as docs/images.toml says, and records their fingerprints.

    python3 scripts/docs-images.py [--raylab PATH] [--only FILE ...] [--records]
    python3 scripts/docs-images.py --fingerprint-only [--only FILE ...]

Builds raylab (release, features mesh,bvh,exr) unless --raylab is given, then for each image of
docs/images.toml: `render` renders each listed command (two side by side, 8 white pixels apart);
`view` serves `raylab view` and takes a headless-Chromium screenshot of the page with the glass
ball's pixel clicked (needs chromium and chromedriver); `run` runs its command ({raylab} is the
binary). `record` images (a dated measurement or comparison the text beside them quotes) are
kept, and remade only with --records, when they have a `run`. Last, it records each image's
fingerprint of each image it made through `RAYLAB_BLESS=FILES cargo test --test docs_images`,
the test that later tells whether the images are current. Needs Pillow.

--fingerprint-only remakes nothing: it records the fingerprints of the images as they are, for
a change that moves fingerprints but no pixel (what the fingerprint is made of, say). Run it
only where `cargo test --test docs_images` passed just before the change: that test is the proof
that the images were current, and nothing since can have changed them.
"""
import argparse
import base64
import json
import os
import subprocess
import sys
import tempfile
import time
import tomllib
import urllib.request

from PIL import Image

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FEATURES = "mesh,bvh,exr"
GAP = 8  # pixels between two renders shown side by side
WINDOW = (1600, 1000)  # the browser window of the view's screenshot (its page: 1600×857)
GLASS_BALL = (310, 330)  # a pixel of the showcase's glass ball (800×600)


def run(cmd, **kw):
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, cwd=ROOT, **kw)


def render(raylab, args, out):
    run([raylab, "render", *args, "-o", out, "-q"])


def beside(paths, out, above=False):
    """The renders side by side, GAP white pixels apart (or one above the other)."""
    images = [Image.open(p).convert("RGB") for p in paths]
    gaps = GAP * (len(images) - 1)
    if above:
        size = (max(i.width for i in images), sum(i.height for i in images) + gaps)
    else:
        size = (sum(i.width for i in images) + gaps, max(i.height for i in images))
    canvas = Image.new("RGB", size, (255, 255, 255))
    at = 0
    for i in images:
        canvas.paste(i, (0, at) if above else (at, 0))
        at += (i.height if above else i.width) + GAP
    canvas.save(out)


def webdriver(port, method, path, body=None):
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(f"http://127.0.0.1:{port}{path}", data=data, method=method, headers={"Content-Type": "application/json"})
    with urllib.request.urlopen(req, timeout=300) as r:
        return json.loads(r.read())["value"]


def wait(port, sid, js, what, seconds=300):
    deadline = time.time() + seconds
    while not webdriver(port, "POST", f"/session/{sid}/execute/sync", {"script": js, "args": []}):
        if time.time() > deadline:
            sys.exit(f"docs-images: timed out waiting for {what}")
        time.sleep(0.3)


def screenshot(raylab, args, out):
    """`raylab view ARGS` in headless Chromium, the glass ball clicked, as a PNG."""
    # --no-refine: the page ends at the scene's samples, the image `raylab render` writes.
    view = subprocess.Popen([raylab, "view", *args, "--port", "0", "--no-refine"], cwd=ROOT, stdout=subprocess.PIPE, text=True)
    port = 9515 + os.getpid() % 1000
    driver = subprocess.Popen(["chromedriver", f"--port={port}"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        url = next(w for w in view.stdout.readline().split() if w.startswith("http://"))
        for _ in range(100):
            try:
                webdriver(port, "GET", "/status")
                break
            except OSError:
                time.sleep(0.1)
        chrome_args = ["--headless=new", "--no-sandbox", "--disable-gpu", "--hide-scrollbars", f"--window-size={WINDOW[0]},{WINDOW[1]}"]
        caps = {"capabilities": {"alwaysMatch": {"goog:chromeOptions": {"args": chrome_args}}}}
        sid = webdriver(port, "POST", "/session", caps)["sessionId"]
        try:
            webdriver(port, "POST", f"/session/{sid}/url", {"url": url})
            wait(port, sid, "return document.body.dataset.phase === 'done'", "the render")
            x, y = GLASS_BALL
            click = f"""const c = document.getElementById('image'); const r = c.getBoundingClientRect();
                c.dispatchEvent(new MouseEvent('click', {{bubbles: true,
                  clientX: r.left + ({x} + 0.5) * r.width / c.width, clientY: r.top + ({y} + 0.5) * r.height / c.height}}));
                return true;"""
            webdriver(port, "POST", f"/session/{sid}/execute/sync", {"script": click, "args": []})
            wait(port, sid, "return !!(window.raylab.explained && window.raylab.explained.tree)", "the explanation")
            time.sleep(0.5)  # the overlay is drawn on the next animation frame
            png = base64.b64decode(webdriver(port, "GET", f"/session/{sid}/screenshot"))
            with open(out, "wb") as f:
                f.write(png)
        finally:
            webdriver(port, "DELETE", f"/session/{sid}")
    finally:
        driver.terminate()
        view.terminate()
        driver.wait()
        view.wait()


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--raylab", help="the raylab binary to use (default: build it)")
    p.add_argument("--only", nargs="+", metavar="FILE", help="only these images (file names in docs/)")
    p.add_argument("--records", action="store_true", help="also remake the records of measurements (then update the text quoting them)")
    p.add_argument(
        "--fingerprint-only",
        action="store_true",
        help="remake nothing: record the current fingerprints (only after a change that moves no pixel, with the images current before it)",
    )
    a = p.parse_args()
    if a.fingerprint_only:
        bless = ",".join(a.only) if a.only else "1"
        env = dict(os.environ, RAYLAB_BLESS=bless)
        run(["cargo", "test", "-p", "raylab-plugins", "--features", FEATURES, "--test", "docs_images"], env=env)
        return
    raylab = a.raylab
    if not raylab:
        run(["cargo", "build", "--release", "-p", "raylab-plugins", "--features", FEATURES])
        raylab = os.path.join(ROOT, "target", "release", "raylab")
    raylab = os.path.abspath(raylab)
    with open(os.path.join(ROOT, "docs", "images.toml"), "rb") as f:
        images = tomllib.load(f)["image"]
    known = {i["file"] for i in images}
    for name in a.only or []:
        if name not in known:
            sys.exit(f"docs-images: {name} is not in docs/images.toml (known: {', '.join(sorted(known))})")
    made = []
    with tempfile.TemporaryDirectory() as tmp:
        for i in images:
            name = i["file"]
            if a.only and name not in a.only:
                continue
            out = os.path.join(ROOT, "docs", name)
            if i.get("record"):
                if a.records and "run" in i:
                    run([w.replace("{raylab}", raylab) for w in i["run"]])
                else:
                    print(f"kept docs/{name}: a record ({i['made_by']})")
                continue
            if "render" in i:
                if len(i["render"]) == 1:
                    render(raylab, i["render"][0], out)
                else:
                    parts = [os.path.join(tmp, f"{k}.png") for k in range(len(i["render"]))]
                    for args, part in zip(i["render"], parts):
                        render(raylab, args, part)
                    beside(parts, out, above=i.get("layout") == "above")
            elif "view" in i:
                screenshot(raylab, i["view"], out)
            elif "run" in i:
                run([w.replace("{raylab}", raylab) for w in i["run"]])
            made.append(name)
    if not made:
        return
    env = dict(os.environ, RAYLAB_BLESS=",".join(made))
    run(["cargo", "test", "-p", "raylab-plugins", "--features", FEATURES, "--test", "docs_images"], env=env)


if __name__ == "__main__":
    main()
