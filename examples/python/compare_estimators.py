#!/usr/bin/env python3
"""Every exact estimator of photongi on one scene, against a path-traced reference: at equal photons
(one frame each) and at equal time (progressive frames, as many as each method fits in the same
budget). Writes OUT/table.md, OUT/results.csv and OUT/compare.png (PSNR and FLIP against time).

    PYTHONPATH=build/python python3 examples/python/compare_estimators.py --scene cornell-box
"""
import argparse
import csv
import os
import time

import photongi


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scene", default="cornell")
    ap.add_argument("--size", default="320x240")
    ap.add_argument("--photons", type=int, default=100_000)
    ap.add_argument("--frames", type=int, default=8, help="progressive frames at most (1, 2, 4, ... up to it)")
    ap.add_argument("--spp", type=int, default=256, help="the reference's samples per pixel")
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--include-brute", action="store_true", help="the O(photons x pixels) oracle too")
    ap.add_argument("--out", default="compare-estimators")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    w, h = (int(x) for x in a.size.split("x"))

    scene = photongi.Scene(a.scene)
    exposure = scene.info["defaults"]["exposure"] or 1.0
    t0 = time.perf_counter()
    ref, spp = photongi.reference(scene, a.spp, size=(w, h), threads=a.threads)
    print("reference: {} spp in {:.1f} s".format(spp, time.perf_counter() - t0))

    names = [e["name"] for e in photongi.estimators() if e["exact"] and (a.include_brute or not e["oracle"])]
    counts = sorted({1} | {1 << k for k in range(32) if 1 << k <= a.frames} | {a.frames})
    renderer = photongi.Renderer(scene)
    rows = []
    for name in names:
        for frames in counts:
            # the same seed, photons and radius sequence for every method: only the estimate differs
            image, stats = renderer.render(estimator=name, photons=a.photons, size=(w, h), frames=frames, seed=1,
                                           threads=a.threads or None, jitter="on")
            m = photongi.compare(image, ref, exposure)
            rows.append(dict(estimator=name, frames=frames, ms=stats["times_ms"]["total"], psnr=m["psnr"],
                             flip=m["flip"]["mean"], relmse=m["relmse"], reads=stats["reads"],
                             contributing=stats["contributing"]))
            print("{:16s} {:3d} frames {:9.1f} ms  PSNR {:6.2f} dB  FLIP {:.4f}".format(
                name, frames, rows[-1]["ms"], m["psnr"], m["flip"]["mean"]))

    with open(os.path.join(a.out, "results.csv"), "w", newline="") as f:
        wr = csv.DictWriter(f, fieldnames=list(rows[0]))
        wr.writeheader()
        wr.writerows(rows)

    # equal photons: one frame each; equal time: each method's best within the budget every method reached
    budget = min(max(r["ms"] for r in rows if r["estimator"] == n) for n in names)
    lines = ["# {} at {}x{}, {} photons, against a {}-spp reference".format(a.scene, w, h, a.photons, spp), "",
             "## Equal photons (one frame)", "",
             "Exact methods compute the same estimate (the brute-force oracle's), so their images agree and "
             "only their time and work differ.", "", "| estimator | ms | PSNR dB | FLIP | relMSE | contributing / read |",
             "|---|---|---|---|---|---|"]
    for r in (r for r in rows if r["frames"] == 1):
        lines.append("| {} | {:.1f} | {:.2f} | {:.4f} | {:.5f} | {:.1f} % |".format(
            r["estimator"], r["ms"], r["psnr"], r["flip"], r["relmse"], 100.0 * r["contributing"] / max(r["reads"], 1)))
    lines += ["", "## Equal time ({:.0f} ms)".format(budget), "", "| estimator | frames | ms | PSNR dB | FLIP |",
              "|---|---|---|---|---|"]
    for n in names:
        fit = [r for r in rows if r["estimator"] == n and r["ms"] <= budget * 1.0001]
        if not fit:
            lines.append("| {} | 0 | (one frame takes longer) | - | - |".format(n))
            continue
        best = max(fit, key=lambda r: r["frames"])
        lines.append("| {} | {} | {:.1f} | {:.2f} | {:.4f} |".format(n, best["frames"], best["ms"], best["psnr"],
                                                                     best["flip"]))
    with open(os.path.join(a.out, "table.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    for n in names:
        rs = [r for r in rows if r["estimator"] == n]
        ax1.plot([r["ms"] for r in rs], [r["psnr"] for r in rs], marker="o", label=n)
        ax2.plot([r["ms"] for r in rs], [r["flip"] for r in rs], marker="o", label=n)
    for ax, label in ((ax1, "PSNR (dB, higher is better)"), (ax2, "FLIP (lower is better)")):
        ax.set_xscale("log")
        ax.set_xlabel("time (ms)")
        ax.set_ylabel(label)
        ax.grid(True, which="both", alpha=0.3)
    ax1.legend(fontsize=8)
    fig.suptitle("{}: {} photons a frame, progressive frames {}".format(a.scene, a.photons, counts))
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "compare.png"), dpi=110)
    print("wrote {}/table.md, results.csv, compare.png".format(a.out))


if __name__ == "__main__":
    main()
