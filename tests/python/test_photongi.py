"""The Python package against the command line and the library: the same image bit for bit, the
same statistics, errors as exceptions with the library's message, no leak over many renders.
CTest runs it (test_python) with PYTHONPATH=BUILD/python and PHOTONGI_CLI=BUILD/bin/photongi."""
import json
import os
import subprocess
import threading

import numpy as np
import pytest

import photongi

CLI = os.environ.get("PHOTONGI_CLI", "photongi")
SMALL = dict(size=(64, 48), photons=4000, seed=3, threads=2)


def cli(*args):
    return subprocess.run([CLI, *args], check=True, capture_output=True, text=True)


@pytest.fixture(scope="module")
def cornell():
    return photongi.Scene("cornell")


def test_version_and_lists():
    assert photongi.__version__ == cli("--version").stdout.split()[1]
    names = [e["name"] for e in photongi.estimators()]
    assert names == cli("estimators").stdout.split()
    tiled = next(e for e in photongi.estimators() if e["name"] == "tiled")
    assert tiled["exact"] and any(o["keyword"] == "tile" for o in tiled["options"])
    assert "cornell" in photongi.builtin_scenes()


def test_scene_info(cornell):
    i = cornell.info
    assert i["triangles"] > 0 and i["lights"] >= 1 and i["cameras"] >= 1
    assert len(i["bounds"]) == 2 and all(lo <= hi for lo, hi in zip(*i["bounds"]))
    assert set(cornell.camera(0)) == {"eye", "look_at", "up", "fov"}
    with pytest.raises(photongi.Error, match="camera"):
        cornell.camera(99)


@pytest.mark.parametrize("est,extra", [("cluster-trivial", []), ("tiled", ["--tile", "8"]),
                                       ("kdtree", ["--knn", "20"]), ("hashgrid", [])])
def test_image_equals_cli_exr(tmp_path, cornell, est, extra):
    """The same settings through Python and through `photongi render`: the same bits."""
    exr, stats = tmp_path / "cli.exr", tmp_path / "cli.json"
    cli("render", "--scene", "cornell", "--estimator", est, "--size", "64x48", "--photons", "4000", "--seed", "3",
        "--threads", "2", *extra, "-q", "-o", str(exr), "--stats", str(stats))
    kw = {extra[0][2:]: int(extra[1])} if extra else {}
    image, st = photongi.Renderer(cornell).render(estimator=est, **SMALL, **kw)
    ref = photongi.read_image(exr)
    assert image.shape == (48, 64, 3) and image.dtype == np.float32
    assert np.array_equal(image, ref)
    c = json.load(open(stats))
    for k in ("estimator", "width", "height", "radius", "photons", "reads", "contributing", "nodes_visited"):
        assert st[k] == c[k], k
    assert st["memory_bytes"].keys() == c["memory_bytes"].keys()
    assert set(st["times_ms"]) == set(c["times_ms"]) and st["times_ms"]["total"] > 0


def test_progressive_and_camera_equal_cli(tmp_path, cornell):
    exr = tmp_path / "p.exr"
    cli("render", "--scene", "cornell", "--size", "64x48", "--photons", "4000", "--seed", "3", "--threads", "2",
        "--estimator", "tiled", "--progressive", "4", "--radius", "auto", "-q", "-o", str(exr))
    image, st = photongi.render(cornell, estimator="tiled", frames=4, radius="auto", **SMALL)
    assert st["frames"] == 4
    assert np.array_equal(image, photongi.read_image(exr))
    # the scene's camera 0 given as a free camera renders the same picture
    r = photongi.Renderer(cornell)
    a, _ = r.render(camera=0, **SMALL)
    b, _ = r.render(camera=cornell.camera(0), **SMALL)
    assert np.array_equal(a, b)


def test_camera_by_name(tmp_path):
    desc = tmp_path / "named.json"
    desc.write_text('{"builtin": "cornell", "cameras": [{"eye": [0.6, 1, 3.6], "look_at": [0, 1, 0], "name": "side"},'
                    ' {"eye": [0, 1, 3.9], "look_at": [0, 1, 0], "name": "front"}]}')
    r = photongi.Renderer(photongi.Scene(str(desc)))
    a, _ = r.render(camera="front", **SMALL)
    b, _ = r.render(camera=1, **SMALL)
    assert np.array_equal(a, b)
    with pytest.raises(ValueError, match="its cameras: 0 'side', 1 'front'"):
        r.render(camera="back", **SMALL)


def test_outputs_add_up(cornell):
    r = photongi.Renderer(cornell)
    full, _ = r.render(**SMALL)
    direct, _ = r.render(output="direct", **SMALL)
    indirect, _ = r.render(output="indirect", **SMALL)
    assert np.allclose(full, direct + indirect, rtol=1e-5, atol=1e-6)
    assert indirect.mean() > 0


def test_errors(tmp_path, cornell):
    with pytest.raises(photongi.Error) as e:
        photongi.Scene("no-such-scene")
    assert "no-such-scene" in str(e.value) and e.value.args[1] == "invalid argument"
    with pytest.raises(photongi.Error, match="missing.obj") as e:
        photongi.Scene(str(tmp_path / "missing.obj"))
    r = photongi.Renderer(cornell)
    with pytest.raises(ValueError, match="photons needs a whole number"):
        r.render(photons=-5)
    with pytest.raises(ValueError, match="unknown estimator 'nope'"):
        r.render(estimator="nope")
    with pytest.raises(ValueError, match="tile"):
        r.render(estimator="tiled", tile=100000)
    with pytest.raises(ValueError, match="frames needs an exact estimator"):
        r.render(estimator="directional", frames=3)
    with pytest.raises(TypeError, match="unknown render setting 'bogus'"):
        r.render(bogus=1)
    with pytest.raises(photongi.Error, match="cannot write|No such file"):
        photongi.write_image(np.zeros((4, 4, 3), np.float32), tmp_path / "no" / "dir" / "x.exr")
    with pytest.raises(photongi.Error):
        photongi.read_image(tmp_path / "missing.exr")
    with pytest.raises(ValueError, match="shape"):
        photongi.compare(np.zeros((4, 4)), np.zeros((4, 4)))


def test_compare_equals_cli(tmp_path, cornell):
    a, _ = photongi.render(cornell, **SMALL)
    b, _ = photongi.render(cornell, **dict(SMALL, photons=1000))
    pa, pb = tmp_path / "a.exr", tmp_path / "b.exr"
    photongi.write_image(a, pa)
    photongi.write_image(b, pb)
    c = json.loads(cli("compare", str(pa), str(pb), "--json").stdout)
    m = photongi.compare(a, b)
    for k in ("psnr", "ssim", "relmse"):
        assert m[k] == pytest.approx(c[k], rel=1e-6, abs=1e-9), k  # (the CLI prints 8 digits)
    assert m["flip"]["mean"] == pytest.approx(c["flip"], rel=1e-6)
    assert m["flip_map"].shape == (48, 64) and m["flip_map"].mean() == pytest.approx(m["flip"]["mean"], rel=1e-5)
    assert photongi.compare(a, a)["psnr"] == float("inf")


def test_reference_resumes(cornell):
    one, n1 = photongi.reference(cornell, 8, size=(24, 16), threads=2)
    half, n = photongi.reference(cornell, 4, size=(24, 16), threads=2)
    two, n2 = photongi.reference(cornell, 4, size=(24, 16), threads=2, resume=(half, n))
    assert n1 == n2 == 8
    assert np.allclose(one, two, rtol=1e-5, atol=1e-7)


def test_moving_light_changes_the_picture():
    s = photongi.Scene("cornell")
    r = photongi.Renderer(s)
    a, _ = r.render(**SMALL)
    light = s.lights()[0]
    x, y, z = light["position"]
    s.set_light_position(0, (x + 0.2, y, z))
    b, _ = r.render(**SMALL)
    assert not np.array_equal(a, b)
    s.set_light_position(0, (x, y, z))
    c, _ = r.render(**SMALL)
    assert np.allclose(a, c, rtol=1e-4, atol=1e-6)


def test_threads_render_while_others_run(cornell):
    """The GIL is released while rendering: renders on separate renderers run side by side and give
    the single-threaded result."""
    want, _ = photongi.render(cornell, **SMALL)
    out = [None] * 3
    scenes = [photongi.Scene("cornell") for _ in out]

    def work(i):
        out[i] = photongi.render(scenes[i], **SMALL)[0]

    ts = [threading.Thread(target=work, args=(i,)) for i in range(3)]
    for t in ts:
        t.start()
    for t in ts:
        t.join()
    assert all(np.array_equal(o, want) for o in out)


def test_no_leak_over_200_renders(cornell):
    r = photongi.Renderer(cornell)

    def rss_kb():
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith("VmRSS:"))

    for _ in range(20):
        r.render(**SMALL)
    before = rss_kb()
    for _ in range(200):
        image, stats = r.render(**SMALL)
        del image, stats
    grown = rss_kb() - before
    # one image is 36 KB; 200 leaked ones would be over 7 MB
    assert grown < 3000, "RSS grew by {} KB over 200 renders".format(grown)
