#!/usr/bin/env python3
"""A camera orbit around a scene, written as PNG frames (OUT/frame-0000.png, ...): one renderer, so the
scene is built once and only the camera moves. Make a video with
`ffmpeg -i OUT/frame-%04d.png orbit.mp4`.

    PYTHONPATH=build/python python3 examples/python/orbit.py --scene cornell-box --frames 36
"""
import argparse
import math
import os

import photongi


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--frames", type=int, default=36)
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--photons", type=int, default=100_000)
    ap.add_argument("--estimator", default=None)
    ap.add_argument("--out", default="orbit")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    scene = photongi.Scene(a.scene)
    cam = scene.camera(0)
    exposure = scene.info["defaults"]["exposure"] or 1.0
    # orbit the scene's first camera about the vertical axis through its look-at point
    (ex, ey, ez), (cx, cy, cz) = cam["eye"], cam["look_at"]
    radius, angle0 = math.hypot(ex - cx, ez - cz), math.atan2(ez - cz, ex - cx)
    renderer = photongi.Renderer(scene)
    for k in range(a.frames):
        t = angle0 + 2.0 * math.pi * k / a.frames
        eye = (cx + radius * math.cos(t), ey, cz + radius * math.sin(t))
        image, stats = renderer.render(camera=dict(eye=eye, look_at=cam["look_at"], up=cam["up"], fov=cam["fov"]),
                                       size=a.size, photons=a.photons, estimator=a.estimator, seed=k + 1)
        path = os.path.join(a.out, "frame-{:04d}.png".format(k))
        photongi.write_image(image, path, exposure)
        print("{} ({:.0f} ms)".format(path, stats["times_ms"]["total"]))


if __name__ == "__main__":
    main()
