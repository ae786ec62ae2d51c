"""The Python package against the CLI: the same numbers, trees, errors; the GIL, cancellation."""

import json
import os
import signal
import sys
import threading
import time
import tomllib

import numpy as np
import OpenEXR
import pytest

import raylab

# Small frames: the tests compare bits, not looks.
SMALL = dict(width=48, height=36)


def read_exr(path):
    """Every channel of an EXR file the CLI wrote, as float32 arrays (RGB as (H, W, 3))."""
    with OpenEXR.File(str(path)) as f:
        ch = {k: np.asarray(c.pixels) for k, c in f.channels().items()}
    out = {"rgb": ch["RGB"]}
    if "Z" in ch:
        out["depth"] = ch["Z"]
    if "normal.X" in ch:
        out["normal"] = np.stack([ch["normal.X"], ch["normal.Y"], ch["normal.Z"]], axis=-1)
    if "albedo" in ch:
        out["albedo"] = ch["albedo"]
    return out


def same_bits(a, b):
    """Bit-for-bit equality of float32 arrays (NaN and -0.0 included)."""
    a, b = np.ascontiguousarray(a, dtype=np.float32), np.ascontiguousarray(b, dtype=np.float32)
    return a.shape == b.shape and np.array_equal(a.view(np.uint32), b.view(np.uint32))


@pytest.mark.parametrize(
    "scene,spp",
    [
        ("scenes/dozen.toml", 4),  # phong, stratified
        ("scenes/path-cornell.toml", 4),  # the path tracer
        ("scenes/showcase.toml", None),  # adaptive anti-aliasing, every shape
    ],
)
def test_rgb_and_layers_are_the_bits_of_the_cli_exr(cli, tmp_path, scene, spp):
    out = tmp_path / "cli.exr"
    flags = ["--width", SMALL["width"], "--height", SMALL["height"]] + (["--spp", spp] if spp else [])
    cli("render", scene, "-o", out, "--aov", "depth,normal,albedo", "-q", *flags)
    ref = read_exr(out)
    img = raylab.load(scene, **SMALL, **({"spp": spp} if spp else {})).render(aov=["depth", "normal", "albedo"])
    assert img.rgb.dtype == np.float32 and img.rgb.shape == (SMALL["height"], SMALL["width"], 3)
    assert img.rgb.any(), "a black image proves nothing"
    assert same_bits(img.rgb, ref["rgb"])
    for layer in ("depth", "normal", "albedo"):
        assert same_bits(img[layer], ref[layer]), layer
    # An image written from Python is the CLI's file, channel for channel.
    img.save(tmp_path / "py.exr")
    mine = read_exr(tmp_path / "py.exr")
    for k in ref:
        assert same_bits(mine[k], ref[k]), k


def test_png_is_the_cli_png(cli, tmp_path):
    cli("render", "scenes/dozen.toml", "-o", tmp_path / "cli.png", "--spp", 2, "-q", "--width", 48, "--height", 36)
    img = raylab.load("scenes/dozen.toml", spp=2, **SMALL).render()
    assert img._repr_png_() == (tmp_path / "cli.png").read_bytes()


def test_the_error_layer_and_target_are_the_cli_s(cli, tmp_path):
    """`target_error` reaches the render, and the error and spp layers and the estimate are the
    CLI's `--aov error` channels and summary line."""
    out = tmp_path / "cli.exr"
    flags = ["--width", SMALL["width"], "--height", SMALL["height"], "--spp", 64, "--target-error", 0.2]
    text = cli("render", "scenes/path-cornell.toml", "-o", out, "--aov", "error", "-q", *flags).stdout
    with OpenEXR.File(str(out)) as f:
        ch = {k: np.asarray(c.pixels) for k, c in f.channels().items()}
    img = raylab.load("scenes/path-cornell.toml", **SMALL, spp=64, target_error=0.2).render(aov=["error"])
    assert img.aovs == ["error", "spp"] and img["error"].shape == (36, 48)
    assert same_bits(img["error"], ch["error"]) and same_bits(img["spp"], ch["spp"])
    assert same_bits(img.rgb, ch["RGB"])
    # The target sends samples where the noise is: pixels stop at different counts.
    assert img["spp"].min() >= 16 and img["spp"].max() > img["spp"].min()
    line = next(l for l in text.splitlines() if "estimated error" in l)
    assert f"relative RMSE {100 * img.estimated_error:.3f} %" in line, line
    assert f"{img.mean_spp:.1f} spp on average" in line, line
    # (Its caustic under the glass ball holds about 1 % of the estimated variance here, at the
    # flag's threshold: the Python property and the CLI's line agree either way.)
    assert (img.estimate_may_read_low is None) == ("may read low" not in line), line
    assert img.estimate_may_read_high is False and "may read high" not in line
    # Below 32 samples a pixel (without a target) the estimate may read high, and says so.
    few = raylab.load("scenes/path-cornell.toml", **SMALL, spp=8).render()
    text = cli("render", "scenes/path-cornell.toml", "-o", tmp_path / "few.png", "--width", SMALL["width"], "--height", SMALL["height"], "--spp", 8).stdout
    assert few.estimate_may_read_high is True and "may read high" in text, text
    # The sun's caustics on environment's floor, found by few samples: the estimate may read low,
    # as the CLI says (its share of the variance is the one the summary prints).
    env = dict(width=48, height=27, spp=1024, target_error=0.1)
    low = raylab.load("scenes/environment.toml", **env).render().estimate_may_read_low
    flags = ["--width", 48, "--height", 27, "--spp", 1024, "--target-error", 0.1]
    text = cli("render", "scenes/environment.toml", "-o", tmp_path / "e.png", *flags).stdout
    assert low is not None and low >= 0.01 and f"may read low: {100 * low:.1f} %" in text, (low, text)
    assert raylab.load("scenes/environment.toml", width=48, height=27, spp=16).render().estimate_may_read_low is None
    # Without the layer asked for, none; below two samples a pixel, no estimate.
    assert "error" not in raylab.load("scenes/path-cornell.toml", **SMALL, spp=2).render()
    assert raylab.load("scenes/path-cornell.toml", **SMALL, spp=1).render().estimated_error is None
    with pytest.raises(TypeError, match="target_error"):
        raylab.load("scenes/path-cornell.toml", target_eror=0.1)
    # A time budget is a setting of the same kind (the render itself would be a timed test).
    assert raylab.load("scenes/path-cornell.toml", spp=64, time_budget=5).sampling == "≤ 64 spp within 5 s"


def test_only_the_layers_asked_for():
    img = raylab.load("scenes/dozen.toml", **SMALL).render(aov=["depth"])
    assert img.aovs == ["depth"] and img["depth"].shape == (36, 48)
    assert np.isinf(img["depth"]).any() and np.isfinite(img["depth"]).any()
    with pytest.raises(KeyError, match="normal"):
        img["normal"]
    # The emission layer: what camera rays see emitted (path-cornell's lamp), zero on the walls.
    lit = raylab.load("scenes/path-cornell.toml", **SMALL).render(aov=["emission"])
    assert lit.aovs == ["emission"] and "emission" in lit and lit["emission"].shape == (36, 48, 3)
    assert (lit["emission"] > 0).any() and (lit["emission"] == 0).any()
    with pytest.raises(ValueError, match="depth, normal, albedo, emission, error or spp"):
        raylab.load("scenes/dozen.toml", **SMALL).render(aov=["dpeth"])


def test_settings_and_set_are_the_cli_flags(cli, tmp_path):
    cli(
        "render", "scenes/dozen.toml", "-o", tmp_path / "a.exr", "-q", "--width", 40, "--height", 30,
        "--spp", 3, "--seed", 7, "--depth", 2, "--set", "glossy_rays=4", "--camera", "fov=30",
    )  # fmt: skip
    scene = raylab.load("scenes/dozen.toml", width=40, height=30, seed=7, set={"integrator.glossy_rays": 4, "camera.fov": 30})
    img = scene.render(spp=3, depth=2)
    assert same_bits(img.rgb, read_exr(tmp_path / "a.exr")["rgb"])
    # The scene itself keeps its settings; with_settings makes a changed copy.
    assert scene.spp == 1 and scene.with_settings(spp=3).spp == 3


def test_stats_count_the_work():
    img = raylab.load("scenes/dozen.toml", spp=2, **SMALL).render()
    st = img.stats
    assert st["camera_rays"] == 2 * 48 * 36
    assert st["rays"] >= st["camera_rays"] and st["counters"]["shadow_rays"] > 0
    assert st["seconds"] > 0 and st["nonfinite_samples"] == 0


@pytest.mark.parametrize(
    "scene,pixel,sample,flags",
    [("scenes/showcase.toml", (330, 280), 0, {}), ("scenes/path-cornell.toml", (200, 150), 3, {"spp": 8})],
)
def test_trace_is_trace_json(cli, scene, pixel, sample, flags):
    args = ["trace", scene, "--pixel", f"{pixel[0]},{pixel[1]}", "--sample", sample, "--json"]
    for k, v in flags.items():
        args += [f"--{k}", v]
    expected = json.loads(cli(*args).stdout)
    got = raylab.load(scene, **flags).trace(pixel=pixel, sample=sample)
    assert got == expected
    assert got["tree"]["hit"] is not None


def test_trace_of_a_ray_and_bad_pixels(cli):
    expected = json.loads(cli("trace", "scenes/dozen.toml", "--ray", "0,1,8:0,0,-1", "--json").stdout)
    scene = raylab.load("scenes/dozen.toml")
    assert scene.trace(ray=((0, 1, 8), (0, 0, -1))) == expected
    with pytest.raises(ValueError, match="outside the 800×600 image"):
        scene.trace(pixel=(800, 0))
    with pytest.raises(ValueError, match="has 1 samples"):
        scene.trace(pixel=(0, 0), sample=1)


def test_plugins_are_plugins_json(cli):
    assert raylab.plugins() == json.loads(cli("plugins", "--json").stdout)
    names = {p["name"] for p in raylab.plugins()["geometries"]}
    assert {"sphere", "mesh", "triangle"} <= names


@pytest.mark.parametrize("name", ["unknown-integrator-param.toml", "syntax-unterminated-string.toml", "nan-fov.toml"])
def test_scene_errors_carry_the_cli_message_and_location(cli, name):
    path = f"tests/malformed/{name}"
    expect = open(path).readline().removeprefix("# expect ").strip()
    where = expect.split(": ", 1)[0]
    line, column = (int(x) for x in where.split(":"))
    with pytest.raises(raylab.SceneError) as e:
        raylab.load(path)
    assert (e.value.file, e.value.line, e.value.column) == (path, line, column)
    assert expect.split(": ", 1)[1] in e.value.message
    # str() is the report the CLI prints after "error: ".
    stderr = cli("render", path, "-o", "/dev/null.png", check=False).stderr
    assert stderr.strip() == f"error: {e.value}".strip()


def test_errors_in_settings_and_text_are_located():
    with pytest.raises(raylab.SceneError) as e:
        raylab.loads("[camera]\nposition = [0, 0, 5]\nlook_at = [0, 0, 0]\n[render]\nwidht = 3\n", name="mine.toml")
    assert (e.value.file, e.value.line, e.value.column) == ("mine.toml", 5, 1)
    assert "width" in e.value.help and e.value.help in str(e.value)
    with pytest.raises(raylab.SceneError, match="has no parameter `max_dpth`") as e:
        raylab.load("scenes/dozen.toml", set={"max_dpth": 3})
    assert e.value.file == "set" and "max_depth" in e.value.help


def test_loads_text_and_dict_give_the_file_s_image():
    text = open("scenes/dozen.toml").read()
    whole = raylab.load("scenes/dozen.toml", **SMALL).render()
    from_text = raylab.loads(text, dir="scenes", **SMALL).render()
    from_dict = raylab.loads(tomllib.loads(text), dir="scenes", **SMALL).render()
    assert same_bits(from_text.rgb, whole.rgb) and same_bits(from_dict.rgb, whole.rgb)


def test_the_sandbox_applies_unless_allowed(tmp_path):
    (tmp_path / "tri.obj").write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    (tmp_path / "inner").mkdir()
    scene = tmp_path / "inner" / "scene.toml"
    scene.write_text('[camera]\nposition = [0.3, 0.3, 3]\nlook_at = [0.3, 0.3, 0]\n[[object]]\ntype = "mesh"\nfile = "../tri.obj"\n')
    with pytest.raises(raylab.SceneError, match="leaves the scene's folder") as e:
        raylab.load(scene)
    assert e.value.line == 6
    img = raylab.load(scene, allow_outside_paths=True, width=8, height=8).render()
    assert img.rgb.shape == (8, 8, 3)
    with pytest.raises(raylab.SceneError, match="exceeds the limit"):
        raylab.load("scenes/dozen.toml", limits={"max_pixels": 1000})


def test_tiles_merge_to_the_whole_image_and_to_cli_parts(cli, tmp_path):
    scene = raylab.load("scenes/dozen.toml", spp=2, **SMALL)
    whole = scene.render(aov=["depth"])
    parts = [scene.render(tile=(i, 3), aov=["depth"]) for i in range(3)]
    assert all(p.is_part for p in parts)
    merged = raylab.merge(parts)
    assert same_bits(merged.rgb, whole.rgb) and same_bits(merged["depth"], whole["depth"])
    # A tile from the CLI and one from Python are parts of one frame.
    cli("render", "scenes/dozen.toml", "--spp", 2, "--width", 48, "--height", 36, "--tile", "0/2", "-o", tmp_path / "t0.exr", "-q")
    scene.render(tile=(1, 2)).save(tmp_path / "t1.exr")
    assert same_bits(raylab.merge([tmp_path / "t0.exr", tmp_path / "t1.exr"]).rgb, whole.rgb)
    with pytest.raises(RuntimeError, match="without all their samples"):
        raylab.merge([tmp_path / "t0.exr"])


SLOW = dict(width=160, height=160, spp=64)


def slow_scene():
    """The path tracer at a size that takes a few seconds (cancelled long before that)."""
    return raylab.load("scenes/path-cornell.toml", **SLOW)


def test_the_gil_is_released_while_rendering():
    # A Python thread's fixed work finishes while a much longer render is still running: with
    # the GIL held by the render it could not run at all before the render returned.
    small_job_done, render_done = [], []
    started = threading.Event()

    def python_work():
        started.wait()
        total = sum(i * i for i in range(300_000))
        small_job_done.append((time.monotonic(), total))

    old = sys.getswitchinterval()
    sys.setswitchinterval(1.0)  # no preemption: only a released GIL lets it run
    try:
        t = threading.Thread(target=python_work)
        t.start()
        slow = raylab.load("scenes/path-cornell.toml", width=120, height=120, spp=16)
        slow.render(progress=lambda done, total: started.set(), threads=1)
        render_done.append(time.monotonic())
        t.join()
    finally:
        sys.setswitchinterval(old)
    assert small_job_done and small_job_done[0][0] < render_done[0]


def test_ctrl_c_cancels_the_render():
    seen = []
    fired = threading.Event()

    def progress(done, total):
        seen.append((done, total))
        if not fired.is_set():
            fired.set()
            os.kill(os.getpid(), signal.SIGINT)

    with pytest.raises(KeyboardInterrupt):
        slow_scene().render(progress=progress)
    assert seen and seen[-1][0] < SLOW["width"] * SLOW["height"] * SLOW["spp"], "cancelled before the last sample"


def test_an_exception_in_the_progress_callback_cancels():
    class Stop(Exception):
        pass

    def progress(done, total):
        raise Stop()

    with pytest.raises(Stop):
        slow_scene().render(progress=progress)


def test_sweep_measures_each_setting_against_the_reference():
    scene = raylab.load("scenes/dozen.toml", **SMALL)
    ref = scene.render(spp=64)
    rows = raylab.sweep(scene, vary={"spp": [1, 4, 16]}, reference=ref)
    assert [r["spp"] for r in rows] == [1, 4, 16]
    errs = [r["rmse"] for r in rows]
    assert errs[0] > errs[1] > errs[2] > 0
    assert any(r["pareto"] for r in rows)
    # The error is the one compare() gives, and a rendered reference is the CLI's --reference auto.
    assert rows[2]["rmse"] == scene.render(spp=16).compare(ref)["rmse"]
    auto = raylab.sweep(scene, vary={"spp": [1]}, reference_spp=16)
    assert auto[0]["rmse"] > 0
