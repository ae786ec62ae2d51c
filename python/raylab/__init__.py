"""raylab from Python: load a scene, render it to NumPy arrays, explain a pixel, sweep knobs.

The same engine as the ``raylab`` command line (the native module calls the core's library
functions the CLI calls): the same scene loader with its limits and sandbox, the same render
loop, the same numbers as the CLI's EXR.

    import raylab
    scene = raylab.load("scenes/showcase.toml", set={"integrator.max_depth": 3}, width=400)
    img = scene.render(spp=16, aov=["depth", "normal", "albedo"])
    img.rgb, img["depth"], img.stats
    tree = scene.trace(pixel=(330, 280), sample=0)
"""

from __future__ import annotations

import itertools
import json
import math
import os
from typing import Any, Callable, Iterable, Mapping, Optional, Sequence, Union

import numpy as np

from . import _raylab
from ._raylab import FEATURES, SceneError, __version__

__all__ = [
    "FEATURES",
    "Image",
    "Scene",
    "SceneError",
    "compare",
    "load",
    "loads",
    "merge",
    "plugins",
    "sweep",
    "use",
]

# The native module scenes are loaded with: raylab's own (the built-in plugins), or a plugin
# crate's module installed by `use()`.
_native = _raylab

PathLike = Union[str, "os.PathLike[str]"]


def use(module) -> None:
    """Loads scenes from now on with `module`'s plugins: a plugin crate's own extension module
    (built with ``raylab_python::init`` and its registry; see python/README.md)."""
    global _native
    for name in ("load", "loads", "plugins", "merge"):
        if not hasattr(module, name):
            raise TypeError(f"{module!r} is not a raylab module (it has no `{name}`)")
    _native = module


# --- TOML text for settings and scenes given as Python values ---------------------------------


def _toml_key(k: str) -> str:
    if k and all(c.isalnum() or c in "_-" for c in k):
        return k
    return json.dumps(k)


def _toml_value(v: Any) -> str:
    """`v` as a TOML value (inline tables for dicts)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        f = float(v)
        if math.isnan(f):
            return "nan"
        if math.isinf(f):
            return "inf" if f > 0 else "-inf"
        return repr(f)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, Mapping):
        return "{ " + ", ".join(f"{_toml_key(str(k))} = {_toml_value(x)}" for k, x in v.items()) + " }"
    if isinstance(v, np.ndarray):
        v = v.tolist()
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} {v!r} as a scene value")


def to_toml(scene: Mapping[str, Any]) -> str:
    """A scene given as a dict (the TOML file's structure: ``{"camera": {...}, "object": [{...}]}``)
    as TOML text: top-level tables as ``[name]``, lists of tables as ``[[name]]``, tables of
    tables (``materials``, ``textures``) as ``[name.key]``."""
    head, body = [], []
    for k, v in scene.items():
        key = _toml_key(str(k))
        if isinstance(v, Mapping) and v and all(isinstance(x, Mapping) for x in v.values()) and k in ("materials", "textures"):
            for name, table in v.items():
                body.append(f"\n[{key}.{_toml_key(str(name))}]")
                body.extend(f"{_toml_key(str(a))} = {_toml_value(b)}" for a, b in table.items())
        elif isinstance(v, Mapping):
            body.append(f"\n[{key}]")
            body.extend(f"{_toml_key(str(a))} = {_toml_value(b)}" for a, b in v.items())
        elif isinstance(v, (list, tuple)) and v and all(isinstance(x, Mapping) for x in v):
            for table in v:
                body.append(f"\n[[{key}]]")
                body.extend(f"{_toml_key(str(a))} = {_toml_value(b)}" for a, b in table.items())
        else:
            head.append(f"{key} = {_toml_value(v)}")
    return "\n".join(head + body) + "\n"


def _set_items(set: Optional[Mapping[str, Any]]) -> Optional[list]:
    """``{"integrator.max_depth": 3}`` as the native ``[(key, TOML value)]``."""
    if not set:
        return None
    return [(str(k), _toml_value(v)) for k, v in set.items()]


def _limits(limits: Optional[Mapping[str, int]]) -> Optional[list]:
    if not limits:
        return None
    return [(str(k), int(v)) for k, v in limits.items()]


# --- Scenes ------------------------------------------------------------------------------------

_SETTINGS = ("width", "height", "spp", "seed", "depth", "integrator", "encoding", "accel")

# Settings of the scene's [render] table taken by name, as the CLI's flags (--target-error, …).
_RENDER_SETTINGS = ("target_error", "target_min_spp", "time_budget")


def _split_settings(settings: dict, set: Optional[Mapping[str, Any]]):
    """`settings` without the [render] ones, and `set` with them as ``render.KEY``; an unknown
    setting is a TypeError."""
    render = {f"render.{k}": settings.pop(k) for k in _RENDER_SETTINGS if k in settings and settings[k] is not None}
    for k in _RENDER_SETTINGS:
        settings.pop(k, None)
    unknown = sorted(k for k in settings if k not in _SETTINGS)
    if unknown:
        raise TypeError(f"unknown setting(s) {', '.join(unknown)}; expected {', '.join(_SETTINGS + _RENDER_SETTINGS)} or set=")
    return settings, ({**(set or {}), **render} or None)


def _progress_callback(progress):
    """A callable ``(done, total)`` from `progress`: a callable as is, True for a tqdm bar."""
    if progress is None or progress is False:
        return None, None
    if progress is True:
        try:
            from tqdm.auto import tqdm
        except ImportError as e:  # pragma: no cover - depends on the environment
            raise ImportError("progress=True shows a tqdm bar: pip install tqdm, or pass a callable") from e
        bar = tqdm(total=1, unit="sample", unit_scale=True)

        def update(done, total):
            if bar.total != total and total:
                bar.total = total
            bar.n = done
            bar.refresh()

        return update, bar
    if callable(progress):
        return progress, None
    raise TypeError("progress: expected a callable (done, total), True (a tqdm bar) or None")


class Scene:
    """A loaded scene with its settings. Loading checks it as the CLI does (every key, the
    limits, the sandbox); settings can be changed per render (``render(spp=...)``) or for good
    (``with_settings``)."""

    def __init__(self, native):
        self._native = native

    name = property(lambda self: self._native.name_, doc="The scene file as given, or the text's name.")
    width = property(lambda self: self._native.width, doc="Image width, pixels.")
    height = property(lambda self: self._native.height, doc="Image height, pixels.")
    spp = property(lambda self: self._native.spp, doc="Samples per pixel.")
    seed = property(lambda self: self._native.seed, doc="Random seed.")
    integrator = property(lambda self: self._native.integrator, doc="The integrator's type name.")
    sampling = property(lambda self: self._native.sampling, doc="'16 spp', or the adaptive settings.")
    encoding = property(lambda self: self._native.encoding, doc="The 8-bit encoding: srgb, linear, linear-truncated.")
    fingerprint = property(lambda self: self._native.fingerprint, doc="The scene, its files and settings, hashed.")
    warnings = property(lambda self: list(self._native.warnings), doc="What loading ignored or approximated.")

    def with_settings(self, *, set: Optional[Mapping[str, Any]] = None, **settings) -> "Scene":
        """The same scene with settings changed: ``width``, ``height``, ``spp``, ``seed``,
        ``depth``, ``integrator``, ``encoding``, ``accel``, ``target_error``, ``target_min_spp``,
        ``time_budget`` (seconds), and ``set`` (``{"render.aa": "adaptive", "camera.aperture":
        0.1, "integrator.max_depth": 5}``; bare keys are integrator parameters, as ``--set``).
        Loads again only when something changed."""
        settings, set = _split_settings(dict(settings), set)
        return Scene(self._native.with_settings(set=_set_items(set), **settings))

    def render(
        self,
        *,
        aov: Iterable[str] = (),
        tile: Optional[Sequence[int]] = None,
        crop: Optional[Sequence[int]] = None,
        pass_: Optional[Sequence[int]] = None,
        threads: Optional[int] = None,
        progress: Union[None, bool, Callable[[int, int], Any]] = None,
        set: Optional[Mapping[str, Any]] = None,
        **settings,
    ) -> "Image":
        """Renders the scene (with any setting changed for this render, as ``with_settings``).

        ``aov``: extra layers, any of depth, normal, albedo, emission (what camera rays see emitted
        before their first surface), error (each pixel's estimated
        standard error of its mean luminance, with ``spp``, its samples). ``tile=(i, n)``: tile i of n (bands
        of rows balanced by estimated work, as ``render --tile I/N``), ``crop=(x0, x1, y0, y1)``,
        ``pass_=(k, n)``: a part of the frame for ``merge``. ``progress``: a callable ``(done,
        total)`` (pixel samples) or True for a tqdm bar. The GIL is released while it renders;
        Ctrl-C (KeyboardInterrupt) cancels it."""
        scene = self.with_settings(set=set, **settings) if (settings or set) else self
        callback, bar = _progress_callback(progress)
        try:
            native = scene._native.render(
                aov=[str(a) for a in aov],
                tile=tuple(tile) if tile is not None else None,
                crop=tuple(crop) if crop is not None else None,
                pass_=tuple(pass_) if pass_ is not None else None,
                threads=threads,
                progress=callback,
            )
        finally:
            if bar is not None:
                bar.close()
        return Image(native, scene=scene)

    def trace(self, pixel: Optional[Sequence[int]] = None, sample: int = 0, ray=None) -> dict:
        """The ray tree of sample `sample` of pixel ``(x, y)`` (or of ``ray=(origin,
        direction)``): what ``raylab trace --json`` prints, as Python values."""
        return json.loads(
            self._native.trace(
                pixel=tuple(pixel) if pixel is not None else None,
                sample=sample,
                ray=(tuple(ray[0]), tuple(ray[1])) if ray is not None else None,
            )
        )

    def __repr__(self) -> str:
        return repr(self._native)


def load(
    path: PathLike,
    *,
    set: Optional[Mapping[str, Any]] = None,
    allow_outside_paths: bool = False,
    limits: Optional[Mapping[str, int]] = None,
    **settings,
) -> Scene:
    """Loads a scene file (``.toml``, the report's ``.xml``, a ``.glb``/``.gltf``).

    Settings as the CLI's flags: ``width``, ``height``, ``spp``, ``seed``, ``depth``,
    ``integrator``, ``encoding``, ``accel``, ``target_error`` (each pixel sampled until its
    estimated relative error is at most this; ``spp`` the cap), ``target_min_spp``,
    ``time_budget`` (seconds of tracing); ``set`` for any other key (``{"integrator.max_depth":
    3, "render.aa": "adaptive", "camera.fov": 30}``). The scene may read files only inside its
    folder unless ``allow_outside_paths=True``; ``limits`` raises or lowers the CLI's limits by
    name (``{"max_pixels": ..., "max_rays": ...}``). A bad scene raises :class:`SceneError`."""
    settings, set = _split_settings(dict(settings), set)
    native = _native.load(
        os.fspath(path), set=_set_items(set), allow_outside_paths=allow_outside_paths, limits=_limits(limits), **settings
    )
    return Scene(native)


def loads(
    source: Union[str, Mapping[str, Any]],
    *,
    name: Optional[str] = None,
    dir: PathLike = ".",
    set: Optional[Mapping[str, Any]] = None,
    allow_outside_paths: bool = False,
    limits: Optional[Mapping[str, int]] = None,
    **settings,
) -> Scene:
    """Loads a scene from TOML text, or from a dict of the TOML file's structure. `name` names it
    in errors (default ``<string>`` or ``<dict>``); relative paths (meshes, textures) resolve
    against `dir`. Otherwise as :func:`load`."""
    settings, set = _split_settings(dict(settings), set)
    if isinstance(source, Mapping):
        text, default_name = to_toml(source), "<dict>"
    elif isinstance(source, str):
        text, default_name = source, "<string>"
    else:
        raise TypeError("loads: expected TOML text or a dict")
    native = _native.loads(
        text,
        name=name or default_name,
        dir=os.fspath(dir),
        set=_set_items(set),
        allow_outside_paths=allow_outside_paths,
        limits=_limits(limits),
        **settings,
    )
    return Scene(native)


def plugins() -> dict:
    """Every registered type and its parameters (``raylab plugins --json``)."""
    return json.loads(_native.plugins())


# --- Images ------------------------------------------------------------------------------------


# The layers an Image may have (render(aov=...)); `error` comes with `spp`.
_LAYERS = ("depth", "normal", "albedo", "emission", "error", "spp")


def _array(buf, height: int, width: int, channels: int) -> np.ndarray:
    a = np.frombuffer(buf, dtype=np.float32)
    return a.reshape((height, width) if channels == 1 else (height, width, channels))


class Image:
    """A render: ``rgb`` (linear float32, ``(H, W, 3)``, the numbers of the CLI's EXR), the
    layers asked for (``img["depth"]``, ``img["error"]``, ``img["spp"]`` ``(H, W)``,
    ``img["normal"]``, ``img["albedo"]``, ``img["emission"]`` ``(H, W, 3)``), ``stats``, ``estimated_error``, ``estimate_may_read_low``, ``estimate_may_read_high``. Shown in Jupyter tone-mapped as the CLI's PNG."""

    def __init__(self, native, scene: Optional[Scene] = None):
        self._native = native
        self.scene = scene
        self._rgb = None
        self._layers: dict = {}

    width = property(lambda self: self._native.width)
    height = property(lambda self: self._native.height)
    complete = property(lambda self: self._native.complete, doc="False when the render was cancelled.")
    encoding = property(lambda self: self._native.encoding)
    is_part = property(lambda self: self._native.is_part, doc="A tile, crop or pass of a frame, for merge().")

    @property
    def rgb(self) -> np.ndarray:
        """Linear RGB, float32, ``(height, width, 3)`` (a view of the native buffer, no copy)."""
        if self._rgb is None:
            self._rgb = _array(self._native.rgb_bytes(), self.height, self.width, 3)
        return self._rgb

    @property
    def stats(self) -> Optional[dict]:
        """Camera rays, the integrator's counters, rays in all, seconds, rays per second."""
        return self._native.stats()

    @property
    def estimated_error(self) -> Optional[float]:
        """The image's estimated relative RMSE of luminance against the converged image, from
        the spread of each pixel's samples (the CLI's ``estimated error`` line); None below two
        samples a pixel."""
        e = self._native.estimated_error()
        return None if e is None else e[0]

    @property
    def estimate_may_read_low(self) -> Optional[float]:
        """Under an error target, where ``estimated_error`` may read low (the CLI's "may read
        low"): part of the image is lit by samples rarer than the target's first stop (caustics,
        glints), or the estimate rests on fewer than 32 pixels' worth of variance. The share of
        the estimated variance in the rarely lit pixels (1 % or more, or less when the flag is
        for few pixels); None otherwise. A larger ``target_min_spp`` looks longer."""
        return self._native.estimate_reads_low()

    @property
    def estimate_may_read_high(self) -> Optional[bool]:
        """Whether ``estimated_error`` may read high: below 32 samples a pixel on average without
        an error target, each half of a pixel's samples is stratified much less well than the
        whole (the CLI's "may read high"; up to 2.3× the true error at 8 spp, 1.55× at 16); None
        without an estimate."""
        return self._native.estimate_reads_high()

    @property
    def mean_spp(self) -> Optional[float]:
        """Mean samples per pixel (under an error target or a time budget, pixels differ)."""
        e = self._native.estimated_error()
        return None if e is None else e[1]

    @property
    def aovs(self) -> list:
        """The layers this image has."""
        return [n for n in _LAYERS if self._layer(n) is not None]

    def _layer(self, name: str):
        if name not in self._layers:
            got = self._native.layer_bytes(name)
            self._layers[name] = None if got is None else _array(got[0], self.height, self.width, got[1])
        return self._layers[name]

    def __getitem__(self, name: str) -> np.ndarray:
        if name in ("rgb", "color", "colour"):
            return self.rgb
        layer = self._layer(name)
        if layer is None:
            raise KeyError(f"{name!r}: the render has no such layer (render(aov=[{name!r}]) computes it)")
        return layer

    def __contains__(self, name: str) -> bool:
        return name in ("rgb", "color", "colour") or (name in _LAYERS and self._layer(name) is not None)

    def png(self) -> bytes:
        """The image as PNG bytes, clamped and encoded as the CLI writes it."""
        return self._native.png()

    def _repr_png_(self) -> bytes:
        return self.png()

    def save(self, path: PathLike, *, half: bool = False) -> None:
        """Writes the image as ``raylab render -o PATH`` does (PNG, JPEG, EXR with the layers,
        PFM); a part of a frame as a partial EXR that ``merge`` and ``raylab merge`` read."""
        self._native.save(os.fspath(path), half=half)

    def compare(self, reference) -> dict:
        """RMSE, PSNR, SSIM and 1 − SSIM against `reference` (an Image, an ``(H, W, 3)`` array
        of linear values, or a .pfm/.png file), on displayed values as ``raylab sweep``."""
        return compare(self, reference)

    def __repr__(self) -> str:
        extra = f", layers {', '.join(self.aovs)}" if self.aovs else ""
        part = ", part of a frame" if self.is_part else ""
        return f"<raylab.Image {self.width}×{self.height}{extra}{part}>"


def merge(parts: Iterable[Union[Image, PathLike]], *, allow_partial: bool = False) -> Image:
    """Merges parts of one frame (Images rendered with ``tile=``, ``crop=`` or ``pass_=``, or
    partial EXR files from ``raylab render --tile``) into the whole image, bit for bit the one
    whole render gives."""
    items = [p._native if isinstance(p, Image) else os.fspath(p) for p in parts]
    return Image(_native.merge(items, allow_partial=allow_partial))


def _linear(image, encoding: str, shape=None) -> np.ndarray:
    if isinstance(image, Image):
        return image.rgb
    if isinstance(image, (str, os.PathLike)):
        w, h, buf = _native.read_reference(os.fspath(image), encoding)
        return _array(buf, h, w, 3)
    a = np.asarray(image, dtype=np.float32)
    if a.ndim != 3 or a.shape[2] != 3:
        raise ValueError(f"expected an (H, W, 3) image, found shape {a.shape}")
    return a


def compare(image, reference, encoding: Optional[str] = None) -> dict:
    """The error of `image` against `reference` (Images, ``(H, W, 3)`` linear arrays, or files),
    on displayed values in `encoding` (default: the image's) as ``raylab sweep`` measures it."""
    enc = encoding or (image.encoding if isinstance(image, Image) else "srgb")
    a = np.ascontiguousarray(_linear(image, enc), dtype=np.float32)
    b = np.ascontiguousarray(_linear(reference, enc), dtype=np.float32)
    if a.shape != b.shape:
        raise ValueError(f"the image is {a.shape[1]}×{a.shape[0]} but the reference {b.shape[1]}×{b.shape[0]}")
    rmse, psnr, ssim = _native.compare(a.tobytes(), b.tobytes(), a.shape[1], a.shape[0], enc)
    return {"rmse": rmse, "psnr": psnr, "ssim": ssim, "dssim": 1.0 - ssim}


# --- Sweeps ------------------------------------------------------------------------------------


def sweep(
    scene: Scene,
    vary: Mapping[str, Sequence[Any]],
    reference=None,
    *,
    one_at_a_time: bool = False,
    repeat: int = 1,
    threads: Optional[int] = None,
    reference_spp: int = 256,
    reference_integrator: Optional[str] = None,
) -> list:
    """Renders `scene` at every combination of the `vary` knobs (or one knob at a time from the
    scene's settings), times each and measures it against `reference`, as ``raylab sweep``.

    Knobs as ``--vary`` takes them: ``spp``, ``depth``, ``integrator``, ``aa``,
    ``aa_threshold``, ``aa_depth``, ``lens_samples``, … (``[render]`` keys), ``aperture``,
    ``focus_distance`` (camera), a light parameter as ``TYPE.PARAM`` for every light of that
    type (``environment.resolution``); any other name is an integrator parameter
    (``light_samples``, ``light_selection``, …). `reference`: an
    Image, an ``(H, W, 3)`` array, a file, or None for the reference ``raylab sweep --reference
    auto`` renders (``reference_spp``, every quality knob at its reference value; another
    integrator with ``reference_integrator``).
    Returns one dict per setting: the knob values, ``seconds``, ``rays``, ``rmse``, ``psnr``,
    ``ssim``, ``dssim`` and ``pareto`` (no other setting is both faster and better)."""
    if repeat < 1:
        raise ValueError("repeat must be at least 1")
    knobs = [(str(k), list(v)) for k, v in vary.items()]
    for name, values in knobs:
        if not values:
            raise ValueError(f"vary {name}: no values")
    if one_at_a_time:
        choices = [()] + [((k, v),) for k, values in knobs for v in values]
    else:
        # The first knob varies fastest, as `raylab sweep` orders its grid.
        grids = itertools.product(*[[(k, v) for v in values] for k, values in reversed(knobs)])
        choices = [tuple(reversed(c)) for c in grids]
    # Every setting is loaded (checked) before anything renders.
    scenes = [_with_knobs(scene, dict(c)) for c in choices]
    if reference is None:
        swept = [(k, [_toml_value(v) for v in values]) for k, values in knobs]
        ref_scene = Scene(scene._native.reference(swept=swept, integrator=reference_integrator, reference_spp=reference_spp))
        reference = ref_scene.render(threads=threads)
    ref = _linear(reference, scene.encoding)
    rows = []
    for c, s in zip(choices, scenes):
        best = None
        for _ in range(repeat):
            img = s.render(threads=threads)
            if best is None or img.stats["seconds"] < best.stats["seconds"]:
                best = img
        err = compare(best, ref, scene.encoding)
        row = dict(c)
        row.update(
            label=" ".join(f"{k}={v}" for k, v in c) or "base",
            seconds=best.stats["seconds"],
            rays=best.stats["rays"],
            **err,
            pareto=False,
        )
        rows.append(row)
    # The Pareto front: by increasing time, each strictly better than every faster one.
    best_err = math.inf
    for row in sorted(rows, key=lambda r: r["seconds"]):
        if row["dssim"] < best_err:
            best_err = row["dssim"]
            row["pareto"] = True
    return rows


def _with_knobs(scene: Scene, knobs: Mapping[str, Any]) -> Scene:
    """`scene` with sweep knobs applied as ``raylab sweep --vary`` applies them (the core's
    ``apply_knob``): ``spp`` implies stratified sampling and the adaptive knobs adaptive
    sampling, unless ``aa`` is given."""
    items = [(str(k), _toml_value(v)) for k, v in knobs.items()]
    return Scene(scene._native.with_settings(knobs=items or None))
