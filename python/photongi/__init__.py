"""photongi from Python: interactive global illumination by photon mapping.

Render a scene into a NumPy array and compare density-estimation methods::

    import photongi
    scene = photongi.Scene("cornell")
    r = photongi.Renderer(scene)
    image, stats = r.render(estimator="tiled", photons=200_000, size=(320, 240))
    print(image.shape, stats["times_ms"]["total"])  # (240, 320, 3), linear radiance

Images are ``float32`` arrays of shape ``(height, width, 3)`` holding linear RGB radiance, row 0
at the top. Every setting of ``photongi render`` is a keyword of :meth:`Renderer.render` (``--radius
auto`` is ``radius="auto"``, ``--cluster-tile 8`` is ``cluster_tile=8``), checked by the same code
as the command line. Failures of the library raise :class:`Error` with its message; bad settings
raise ``ValueError`` or ``TypeError``. The library renders with the GIL released.
"""

import json as _json
import threading as _threading

from . import _photongi
from ._photongi import Error

__all__ = ["Error", "Scene", "Renderer", "render", "reference", "compare", "estimators", "builtin_scenes",
           "devices", "read_image", "write_image", "__version__"]

__version__ = _photongi.version()


def _flag(key):
    return "--" + key.replace("_", "-")


def _value(key, v):
    """A setting as the command line writes it."""
    if isinstance(v, bool):
        raise TypeError("{}: expected a number or a string, got {!r}".format(key, v))
    if key == "size" and not isinstance(v, str):
        return "{}x{}".format(*_size(v))
    if isinstance(v, float):
        return repr(v)
    return str(v)


class Scene:
    """A scene: a built-in name ("cornell"), a shipped scene's name ("sibenik", looked up in
    scenes/ and $PHOTONGI_SCENES), a scene description (.json) or a mesh file Assimp reads.

    ``info`` holds its counts (triangles, lights, cameras, ...), bounds and suggested defaults.
    Lights and animated objects move between frames: :meth:`set_light_position`, :meth:`set_time`.
    """

    def __init__(self, spec="cornell"):
        if not isinstance(spec, str):
            spec = str(spec)  # a pathlib.Path
        self._cap = _photongi.scene_load(spec)
        self._lock = _threading.RLock()  # renders and changes of this scene, one at a time
        self.spec = spec

    @property
    def info(self):
        """Counts, bounds, camera 0 and the description's suggested defaults, as a dict."""
        return _photongi.scene_info(self._cap)

    def camera(self, index=0):
        """Camera `index` of the scene: a dict with eye, look_at, up and fov (vertical, degrees)."""
        return _photongi.scene_camera(self._cap, index)

    def lights(self):
        """The lights a user can move: point, spot and sun lights, then one group per emissive
        material (kind, name, position, triangles)."""
        return _photongi.scene_lights(self._cap)

    def set_light_position(self, index, position):
        """Moves light group `index` (see :meth:`lights`) to `position` (x, y, z)."""
        with self._lock:
            _photongi.scene_set_light_position(self._cap, index, tuple(float(c) for c in position))

    def set_time(self, t):
        """Moves every animated object to time `t` (seconds)."""
        with self._lock:
            _photongi.scene_set_time(self._cap, float(t))

    def set_specular(self, model):
        """The model of the mesh's glossy materials: "ggx", "phong" or "default"."""
        with self._lock:
            _photongi.scene_set_specular(self._cap, model)

    def __repr__(self):
        i = self.info
        return "photongi.Scene({!r}: {} triangles, {} lights, {} cameras)".format(
            self.spec, i["triangles"], i["lights"], i["cameras"])


class Renderer:
    """Renders frames of one scene, keeping its ray-tracing scene, buffers and estimator between
    calls (a sweep or an animation does not rebuild them). The scene must not be changed by
    another thread during a render (the scene's lock sees to it for the methods here)."""

    def __init__(self, scene):
        if not isinstance(scene, Scene):
            scene = Scene(scene)
        self.scene = scene
        self._cap = _photongi.renderer_create(scene._cap)

    def render(self, *, estimator=None, photons=None, radius=None, size=None, camera=None, seed=None,
               threads=None, device=None, frames=None, output=None, time=None, specular=None, **settings):
        """Renders one frame, or the average of `frames` progressive frames, and returns
        ``(image, stats)``: the linear image as a float32 array (height, width, 3) and the frame's
        statistics as a dict (what ``photongi render --stats`` writes: times per pass, photons
        read and contributing, memory, the settings used).

        estimator  a registered name (:func:`estimators`); default "cluster-trivial"
        photons    photons to store; radius: scene units, or "auto"
        size       (width, height) or "WxH"; default the scene's or 640x480
        camera     a camera index or name of the scene, or a dict / tuple (eye, look_at, up, fov)
        seed, threads, device ("cpu", "vulkan", "vulkan:N"), frames (progressive average)
        output     "all", "direct", "indirect" or "counts"
        time       moves the scene's animated objects first; specular: "ggx" or "phong" first
        settings   any other setting of ``photongi render`` with '-' written '_': bounces,
                   direct_samples, jitter, emission, store, radius_policy, r_min, r_max, smoothing,
                   filter, max_memory, and the estimators' options (cluster_tile, kernel, knn, ...)
        """
        named = dict(estimator=estimator, photons=photons, radius=radius, size=size, seed=seed, threads=threads,
                     device=device, progressive=frames, output=output)
        for key in settings:
            if key in ("exposure", "progressive"):
                raise TypeError("render() got an unexpected setting {!r} (exposure belongs to write_image and "
                                "compare; frames is the progressive count)".format(key))
        named.update(settings)
        pairs = [(_flag(k), _value(k, v)) for k, v in named.items() if v is not None]
        view = None
        if camera is not None:
            if isinstance(camera, int) and not isinstance(camera, bool):
                pairs.append(("--camera", str(camera)))
            elif isinstance(camera, str):
                pairs.append(("--camera", camera))
            else:
                view = _view(camera)
        with self.scene._lock:
            if time is not None:
                _photongi.scene_set_time(self.scene._cap, float(time))
            if specular is not None:
                _photongi.scene_set_specular(self.scene._cap, specular)
            try:
                image, stats = _photongi.render(self._cap, pairs, view)
            except ValueError as e:  # name the setting as the caller wrote it
                msg = str(e).replace("--progressive", "frames")
                for k in named:
                    msg = msg.replace(_flag(k), k)
                raise ValueError(msg) from None
        return image, _json.loads(stats)


def _view(camera):
    if isinstance(camera, dict):
        try:
            c = (camera["eye"], camera["look_at"], camera.get("up", (0.0, 1.0, 0.0)), camera.get("fov", 45.0))
        except KeyError as e:
            raise TypeError("camera: a dict needs 'eye' and 'look_at' (and may have 'up', 'fov')") from e
    else:
        c = tuple(camera)
        if len(c) != 4:
            raise TypeError("camera: an index, a dict, or (eye, look_at, up, fov)")
    eye, at, up, fov = c
    return (tuple(float(x) for x in eye), tuple(float(x) for x in at), tuple(float(x) for x in up), float(fov))


def render(scene="cornell", **settings):
    """One frame of `scene` (a :class:`Scene` or its spec) with a fresh renderer: returns
    ``(image, stats)`` as :meth:`Renderer.render`, which takes the same settings."""
    return Renderer(scene).render(**settings)


_JITTER = {"auto": 0, "off": 1, "on": 2}


def reference(scene, spp, *, size=None, bounces=0, seed=1, threads=0, camera=0, time_limit=0.0, jitter="auto",
              resume=None):
    """The path-traced reference of `scene` (what ``photongi reference`` computes): adds `spp`
    samples per pixel and returns ``(mean, samples)``, the mean image and the samples in it.

    resume      a previous ``(mean, samples)`` of the same settings: the new samples continue its
                sample stream (the result matches one long run up to float rounding)
    time_limit  seconds: stop after the pass that reaches it (0: none)
    jitter      "auto" / "on": the pixel integral; "off": pixel centres
    """
    if not isinstance(scene, Scene):
        scene = Scene(scene)
    w, h = (0, 0) if size is None else _size(size)
    if jitter not in _JITTER:
        raise ValueError("jitter must be 'auto', 'on' or 'off', got {!r}".format(jitter))
    prev, have = (None, 0) if resume is None else resume
    with scene._lock:
        return _photongi.reference(scene._cap, w, h, int(bounces), int(seed), int(threads), int(camera), int(spp),
                                   float(time_limit), _JITTER[jitter], prev, int(have))


def _size(size):
    """(width, height) from (width, height) or "WIDTHxHEIGHT"."""
    try:
        w, h = size.split("x") if isinstance(size, str) else size
        return int(w), int(h)
    except (TypeError, ValueError):
        raise TypeError("size: expected (width, height) or 'WIDTHxHEIGHT', got {!r}".format(size)) from None


def compare(a, b, exposure=1.0):
    """Metrics of image `a` against the reference `b` (arrays (H, W, 3), linear): a dict with psnr
    (dB, on tone-mapped sRGB), ssim, flip (LDR-FLIP: mean, median, quartiles), relmse (on linear
    values), mse, max_abs, and the FLIP map as a float32 array (H, W) under "flip_map" -- what
    ``photongi compare`` reports."""
    metrics, flip_map = _photongi.compare(a, b, float(exposure))
    metrics["flip_map"] = flip_map
    return metrics


def estimators():
    """The registered estimators: name, summary, exact, gpu (has a GPU version), and their options
    (name as the command line writes it, keyword as render() takes it, type, min, max, choices,
    default, help)."""
    ests = _photongi.estimators()
    for e in ests:
        for o in e["options"]:
            o["keyword"] = o["name"].replace("-", "_")
    return ests


def builtin_scenes():
    """The names of the scenes built into the library."""
    return _photongi.builtin_scenes()


def devices():
    """The Vulkan devices (device spec, name, driver); empty without the Vulkan backend."""
    return _photongi.devices()


def read_image(path):
    """An EXR, PNG, HDR or JPEG file as a linear float32 array (H, W, 3)."""
    return _photongi.read_image(str(path))


def write_image(image, path, exposure=1.0):
    """Writes an (H, W, 3) linear image: EXR (linear) or PNG (exposure, then sRGB), by extension."""
    _photongi.write_image(image, str(path), float(exposure))
