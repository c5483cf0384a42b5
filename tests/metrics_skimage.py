#!/usr/bin/env python3
"""Validates `photongi compare` against scikit-image (an independent SSIM/PSNR).

usage: metrics_skimage.py PHOTONGI_BINARY

Generates image pairs (noise, blur, shifts, identical, minimal size, real
renders, an EXR against its own PNG), runs `photongi compare A B --json` and
checks PSNR, SSIM on luma and the mean per-channel SSIM against
skimage.metrics with gaussian_weights=True, sigma=1.5,
use_sample_covariance=False, data_range=1, within 1e-3 (PSNR: 1e-3 dB).
Also checks the errors for a size mismatch and an unreadable file.
Needs Debian's python3-skimage (scripts/install-deps.sh installs it).
"""
import json
import os
import shutil
import subprocess
import sys
import tempfile

try:
    import numpy as np
    from skimage import io as skio
    from skimage.filters import gaussian
    from skimage.metrics import peak_signal_noise_ratio, structural_similarity
except ImportError as e:  # a missing dependency is a failure, not a skip
    sys.exit("test_metrics_skimage: FAILED: python3-skimage/python3-numpy missing (%s); "
             "run scripts/install-deps.sh or 'apt-get install python3-skimage'" % e)

TOL = 1e-3
LUMA = np.array([0.2126, 0.7152, 0.0722])


def ssim(a, b, **kw):
    return structural_similarity(a, b, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                                 data_range=1.0, **kw)


def expected(pa, pb):
    a = skio.imread(pa)[..., :3].astype(np.float64) / 255.0
    b = skio.imread(pb)[..., :3].astype(np.float64) / 255.0
    psnr = None if np.array_equal(a, b) else peak_signal_noise_ratio(b, a, data_range=1.0)
    return {"psnr": psnr, "ssim": ssim(a @ LUMA, b @ LUMA), "ssim_rgb": ssim(a, b, channel_axis=2)}


def compare(exe, a, b):
    r = subprocess.run([exe, "compare", a, b, "--json"], capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit("compare %s %s failed (%d): %s" % (a, b, r.returncode, r.stderr))
    return json.loads(r.stdout)


def save(path, img):
    skio.imsave(path, np.clip(np.rint(img), 0, 255).astype(np.uint8), check_contrast=False)


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    exe = os.path.abspath(sys.argv[1])
    tmp = tempfile.mkdtemp(prefix="pgi-test-skimage-")
    try:
        rng = np.random.default_rng(12345)
        pairs = []

        def pair(name, a, b):
            pa, pb = os.path.join(tmp, name + "_a.png"), os.path.join(tmp, name + "_b.png")
            save(pa, a)
            save(pb, b)
            pairs.append((name, pa, pb))

        h, w = 80, 96
        yy, xx = np.mgrid[0:h, 0:w]
        scene = np.stack([255 * xx / w, 255 * yy / h, 128 + 100 * ((xx // 8 + yy // 8) % 2 - 0.5)], axis=2)
        noise = rng.uniform(0, 255, (h, w, 3))
        pair("noise", noise, noise + rng.normal(0, 20, noise.shape))
        pair("noise_vs_noise", noise, rng.uniform(0, 255, (h, w, 3)))
        pair("blur", scene, 255 * gaussian(scene / 255, sigma=2, channel_axis=2))
        pair("shift1", scene, np.roll(scene, 1, axis=1))
        pair("shift3", scene, np.roll(np.roll(scene, 3, axis=0), -2, axis=1))
        pair("dark_noise", 20 * scene / 255, 20 * scene / 255 + rng.normal(0, 3, scene.shape))
        pair("identical", scene, scene)
        small = rng.uniform(0, 255, (11, 13, 3))
        pair("minimal", small, small + rng.normal(0, 30, small.shape))

        # Real renders: few vs many photons, and an EXR reference (compare
        # tone-maps it) checked against the PNG the reference command writes.
        env = dict(os.environ)
        def run(*args):
            r = subprocess.run([exe, *args], capture_output=True, text=True, env=env)
            if r.returncode != 0:
                sys.exit("photongi %s failed: %s" % (" ".join(args), r.stderr))
        lo, hi = os.path.join(tmp, "lo.png"), os.path.join(tmp, "hi.png")
        ref_exr, ref_png = os.path.join(tmp, "ref.exr"), os.path.join(tmp, "ref.png")
        run("render", "--scene", "cornell", "--size", "96x72", "--photons", "5000", "-q", "-o", lo)
        run("render", "--scene", "cornell", "--size", "96x72", "--photons", "100000", "-q", "-o", hi)
        run("reference", "--scene", "cornell", "--size", "96x72", "--spp", "16", "-q", "-o", ref_exr, "--png", ref_png)
        pairs.append(("render_lo_vs_hi", lo, hi))
        pairs.append(("render_vs_reference_png", lo, ref_png))

        worst = 0.0
        for name, pa, pb in pairs:
            got, exp = compare(exe, pa, pb), expected(pa, pb)
            for k in ("psnr", "ssim", "ssim_rgb"):
                if exp[k] is None or got[k] is None:
                    if exp[k] is not None or got[k] is not None:
                        sys.exit("%s: %s: photongi %s, skimage %s" % (name, k, got[k], exp[k]))
                    continue
                d = abs(got[k] - exp[k])
                worst = max(worst, d)
                if d > TOL:
                    sys.exit("%s: %s differs: photongi %.6f, skimage %.6f (|d| = %.2e > %g)"
                             % (name, k, got[k], exp[k], d, TOL))
            print("%-26s PSNR %-10s SSIM %.5f / skimage %.5f   SSIM-RGB %.5f / %.5f"
                  % (name, "inf" if got["psnr"] is None else "%.4f" % got["psnr"], got["ssim"], exp["ssim"],
                     got["ssim_rgb"], exp["ssim_rgb"]))
        # The EXR compares exactly like the PNG written from it (on the tone-mapped bytes: not
        # relMSE, which is on linear values before the 8-bit quantisation).
        e1, e2 = compare(exe, lo, ref_exr), compare(exe, lo, ref_png)
        e1.pop("relmse"), e2.pop("relmse")
        if e1 != e2:
            sys.exit("EXR reference and its PNG compare differently: %s vs %s" % (e1, e2))

        # Errors: size mismatch, unreadable file, too small: the images are at fault, not the
        # command line, so exit status 1 (2 is a usage error; see 'photongi --help').
        def expect_fail(args, code, text):
            r = subprocess.run([exe, "compare", *args], capture_output=True, text=True)
            if r.returncode != code or text not in r.stderr:
                sys.exit("compare %s: expected exit %d and '%s', got %d: %s" % (args, code, text, r.returncode, r.stderr))
        tiny = os.path.join(tmp, "tiny.png")
        save(tiny, rng.uniform(0, 255, (8, 8, 3)))
        bogus = os.path.join(tmp, "bogus.png")
        with open(bogus, "w") as f:
            f.write("not an image")
        expect_fail([lo, pairs[0][1]], 1, "sizes differ")
        expect_fail([lo, os.path.join(tmp, "missing.png")], 1, "missing.png")
        expect_fail([lo, bogus], 1, "bogus.png")
        expect_fail([tiny, tiny], 1, "11x11")
        print("all %d pairs within %g of scikit-image (worst %.2e)" % (len(pairs), TOL, worst))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
