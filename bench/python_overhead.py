#!/usr/bin/env python3
"""What a render through the Python package costs over the same frame through the C API: the wall
time of Renderer.render() (settings parsed, the frame, the image wrapped as an array, the stats
decoded) against the library's own time for that frame (stats total_ms: pgi_renderer_render's
work, what a C caller waits for). Medians over the frames after a warm-up.

    PYTHONPATH=build/python python3 bench/python_overhead.py [--scene sibenik] [--size 1920x1080] [--frames 10]
"""
import argparse
import statistics
import time

import photongi

ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
ap.add_argument("--scene", default="sibenik")
ap.add_argument("--size", default="1920x1080")
ap.add_argument("--photons", type=int, default=200_000)
ap.add_argument("--frames", type=int, default=10)
a = ap.parse_args()
r = photongi.Renderer(photongi.Scene(a.scene))
r.render(size=a.size, photons=a.photons)  # warm-up: the BVH, the buffers, the estimator
walls, libs = [], []
for k in range(a.frames):
    t0 = time.perf_counter()
    image, stats = r.render(size=a.size, photons=a.photons, seed=k + 1)
    walls.append((time.perf_counter() - t0) * 1e3)
    libs.append(stats["times_ms"]["total"])
    del image
over = [w / l - 1.0 for w, l in zip(walls, libs)]
print("{} {} {} photons, {} frames: render() {:.1f} ms, the library's frame {:.1f} ms (medians); "
      "overhead {:+.2f} % (median of the frames' ratios; {:.2f} ms)".format(
          a.scene, a.size, a.photons, a.frames, statistics.median(walls), statistics.median(libs),
          100 * statistics.median(over), statistics.median(w - l for w, l in zip(walls, libs))))
