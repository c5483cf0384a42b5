#!/usr/bin/env python3
"""The report of bench/gpu_suite.sh: reads what its steps left in the work folder and writes
OUT/DEVICE-DATE.md (markdown) and OUT/DEVICE-DATE.csv (every measured frame configuration), then
prints the short table. Standard library only (it runs on the GPU machine's Python as well)."""
import argparse
import csv
import datetime
import json
import os
import re
import statistics
import sys

# The targets on a GPU (Sibenik 1080p, 200k photons, cluster-trivial)
TARGETS = {"splat_ms": 5.0, "frame_ms": 12.0}


def read(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    except OSError:
        return ""


def rows(path):
    try:
        with open(path, newline="", encoding="utf-8") as f:
            return list(csv.DictReader(f))
    except OSError:
        return []


def passes(row):
    out = {}
    for item in (row.get("passes") or "").split(";"):
        if "=" in item:
            k, v = item.split("=", 1)
            try:
                out[k] = float(v)
            except ValueError:
                pass
    return out


def fl(x):
    """A CSV field as a float, None when it is missing or not a number."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return None


def num(x, fmt="{:.1f}"):
    try:
        return fmt.format(float(x))
    except (TypeError, ValueError):
        return "-"


def mib(x):
    try:
        return "{:.1f}".format(float(x) / 1048576.0)
    except (TypeError, ValueError):
        return "-"


def slug(name):
    s = re.sub(r"\(.*?\)", "", name).strip().lower()
    s = re.sub(r"[^a-z0-9]+", "-", s).strip("-")
    return s or "unknown"


def table(header, body):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in body]
    return "\n".join(out)


def code(text, limit=6000):
    text = text.strip()
    if len(text) > limit:
        text = text[:limit] + "\n... (cut; the whole output is in raw.tar.gz)"
    return "```\n" + (text or "(no output)") + "\n```"


# Sub-passes shown for each GPU estimator in the frame tables (the rest are in the CSV).
KEY_PASSES = ["gpu_view", "gpu_trace", "gpu_readback", "gpu_view_download", "gpu_trace_download",
              "gpu_photon_order", "gpu_splat", "gpu_lists", "gpu_sort", "gpu_gather", "gpu_radiance", "gpu_direct",
              "gpu_download"]


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--work", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--device", default="unknown")
    ap.add_argument("--mode", default="full")
    ap.add_argument("--source", default="")
    a = ap.parse_args()
    W = lambda name: os.path.join(a.work, name)
    today = datetime.date.today().isoformat()
    if a.device == "unknown":  # the device column of the frames, where the suite could not tell
        a.device = next((r.get("device") for r in rows(W("frame-sibenik.csv")) + rows(W("frame-crytek-sponza-paper.csv"))
                         if r.get("device") and r.get("device") != "cpu"), "unknown")
    base = "{}-{}".format(slug(a.device), today)
    steps = rows(W("steps.csv"))
    env = read(W("env.out"))
    devices = read(W("devices.out"))
    md = []
    md.append("# photongi on {} ({})".format(a.device, today))
    md.append("")
    md.append("`bench/gpu_suite.sh` ({} sizes), from the {}. Figures are medians of the frames measured after "
              "a warm-up frame (photongi-bench), milliseconds unless said otherwise; one run, on a machine "
              "lent for minutes: read ratios between rows first.".format(a.mode, a.source))
    md.append("")
    md.append("## Machine")
    md.append(code(env + "\n" + devices))
    md.append("")
    md.append("## Steps")
    md.append(table(["step", "status", "seconds", "limit"],
                    [[s["step"], s["status"], s["seconds"], s["limit"]] for s in steps]))
    md.append("")

    # --- correctness
    tests = rows(W("tests.csv"))
    md.append("## Correctness on the device")
    md.append("The GPU tests (GPU estimators against the CPU brute force on identical photons, the GPU frame "
              "against the CPU frame, rays against Embree, the GPU tracer against the CPU's) on the device the "
              "library picks.")
    md.append("")
    md.append(table(["test", "exit", "passed", "failed", "device", "seconds"],
                    [[t["test"], t["exit"], t["passed"] or "-", t["failed"] or "0", t["device"] or "-", t["seconds"]]
                     for t in tests]) if tests else "(the tests did not run)")
    failed_lines = []
    for t in tests:
        if t["exit"] != "0":
            log = read(W(t["test"] + ".log"))
            failed_lines.append("### {} (exit {})\n{}".format(
                t["test"], t["exit"], code("\n".join(log.splitlines()[-60:]), 8000)))
    if failed_lines:
        md.append("")
        md += failed_lines
    md.append("")

    # --- the GPU frame
    frame_rows = []
    md.append("## The GPU frame")
    for scene in ("sibenik", "crytek-sponza-paper"):
        rs = rows(W("frame-{}.csv".format(scene)))
        frame_rows += [dict(r, suite_step="frame-" + scene) for r in rs]
        md.append("### {}".format(scene))
        if not rs:
            md.append("(no rows: see the step's output in raw.tar.gz and suite.log)")
            md.append("")
            continue
        r0 = rs[0]
        md.append("{}x{}, radius: the scene's default (the CSV has the radius each row used), device {}.".format(
            r0["width"], r0["height"], r0.get("device", "")))
        md.append("")
        body = []
        for r in rs:
            p = passes(r)
            body.append([r["estimator"], r["photons"], r["frames"], num(r["radius"], "{:.3g}"), num(r["total_ms"]),
                         num(r["view_ms"]), num(r["trace_ms"]), num(r["build_ms"]), num(r["estimate_ms"]),
                         num(r["direct_ms"]), num(p.get("gpu_splat")), mib(r.get("gpu_bytes")),
                         "{} / {}".format(num((fl(r.get("reads")) or 0) / 1e6), num((fl(r.get("contributing")) or 0) / 1e6))])
        md.append(table(["estimator", "photons", "frames", "radius", "**frame**", "view", "trace", "build",
                         "estimate", "direct", "splat", "GPU MiB", "reads / contributing (M)"], body))
        md.append("")
        md.append("Sub-passes by estimator (GPU timestamps; readback, upload, submit and download are the "
                  "host's wall clock):")
        md.append("")
        for est in dict.fromkeys(r["estimator"] for r in rs):
            er = [r for r in rs if r["estimator"] == est]
            names = []
            for r in er:
                for k in passes(r):
                    if k not in names:
                        names.append(k)
            names = [n for n in KEY_PASSES if n in names] + [n for n in names if n not in KEY_PASSES]
            md.append("**{}**".format(est))
            md.append("")
            md.append(table(["photons"] + names, [[r["photons"]] + [num(passes(r).get(n)) for n in names] for r in er]))
            md.append("")

    # --- rays, photon tracing
    md.append("## Rays (photongi-bench-gpu-rays)")
    md.append(code(read(W("rays.out"))))
    md.append("")
    md.append("## Photon tracing alone (photongi-bench-gpu-trace)")
    md.append(code(read(W("trace.out"))))
    md.append("")

    # --- CPU scaling
    cpu = rows(W("cpu-scaling.csv"))
    frame_rows += [dict(r, suite_step="cpu-scaling") for r in cpu]
    md.append("## The CPU frame by thread count")
    if cpu:
        r0 = cpu[0]
        md.append("{} {}x{}, {} photons, {} (the default estimator), on the CPU.".format(
            r0["scene"], r0["width"], r0["height"], r0["photons"], r0["estimator"]))
        md.append("")
        one = next((fl(r["total_ms"]) for r in cpu if r["threads"] == "1"), None)
        body = []
        for r in cpu:
            t, n = fl(r["total_ms"]), fl(r["threads"])
            sp = one / t if one and t else None
            body.append([r["threads"], r["frames"], num(r["view_ms"]), num(r["trace_ms"]), num(r["build_ms"]),
                         num(r["estimate_ms"]), num(r["direct_ms"]), num(r["total_ms"]),
                         "{:.2f}x".format(sp) if sp else "-",
                         "{:.0f} %".format(100 * sp / n) if sp and n else "-"])
        md.append(table(["threads", "frames", "view", "trace", "build", "estimate", "direct", "**frame**",
                         "speed-up", "efficiency"], body))
    else:
        md.append("(no rows)")
    md.append("")
    md.append("## Ray passes against raw Embree on every core (photongi-bench --limits)")
    md.append(code(read(W("limits.out"))))
    md.append("")

    # --- images
    md.append("## The same frame on the GPU and on the CPU")
    cmp = {}
    try:
        cmp = json.loads(read(W("compare.json")) or "{}")
    except ValueError:
        pass
    if cmp:
        md.append("Sibenik, {}x{}: `sibenik-vulkan.png` against `sibenik-cpu.png` (the difference: "
                  "`sibenik-diff.png`). Each device traces its own photons (independent photon maps), so the "
                  "PSNR is bounded by the photon noise, not only by the devices' differences.".format(
                      cmp.get("width"), cmp.get("height")))
        md.append("")
        md.append(table(["PSNR dB", "SSIM", "FLIP", "relMSE"],
                        [[num(cmp.get("psnr"), "{:.2f}"), num(cmp.get("ssim"), "{:.4f}"),
                          num(cmp.get("flip"), "{:.4f}"), num(cmp.get("relmse"), "{:.5f}")]]))
    else:
        md.append("(no comparison: see suite.log)")
    md.append("")

    # --- targets and the short table
    sib = rows(W("frame-sibenik.csv"))
    cts = sorted((r for r in sib if r["estimator"] == "cluster-trivial"), key=lambda r: fl(r["photons"]) or 0)
    ct = next((r for r in cts if r["photons"] == "200000"), cts[0] if cts else None)
    summary = []
    summary.append(["device", a.device])
    ok_tests = sum(1 for t in tests if t["exit"] == "0")
    summary.append(["GPU tests", "{} of {} programs passed ({} tests)".format(
        ok_tests, len(tests), int(sum(fl(t["passed"]) or 0 for t in tests))) if tests else "did not run"])
    if ct:
        # the targets are for 1920x1080 and 200k photons; other sizes (--quick) are only reported
        at_target = ct["photons"] == "200000" and ct["width"] == "1920" and ct["height"] == "1080"
        splat = passes(ct).get("gpu_splat")
        frame = fl(ct["total_ms"])

        def verdict(v, t):
            if not at_target:
                return ""
            return " (target <= {:g}: {})".format(t, "met" if v is not None and v <= t else "NOT met")
        label = "Sibenik {}x{} {} photons cluster-trivial".format(ct["width"], ct["height"], ct["photons"])
        summary.append([label + ": splat", "{} ms{}".format(num(splat), verdict(splat, TARGETS["splat_ms"]))])
        summary.append([label + ": frame", "{} ms{}".format(num(frame), verdict(frame, TARGETS["frame_ms"]))])
    else:
        summary.append(["Sibenik cluster-trivial", "not measured"])
    for scene_rows, label in ((sib, "Sibenik"), (rows(W("frame-crytek-sponza-paper.csv")), "Sponza")):
        for p in sorted({r["photons"] for r in scene_rows}, key=lambda p: fl(p) or 0):
            best = min((r for r in scene_rows if r["photons"] == p), key=lambda r: fl(r["total_ms"]) or float("inf"))
            summary.append(["{} {} photons: fastest GPU frame".format(label, p),
                            "{} ms ({})".format(num(best["total_ms"]), best["estimator"])])
    if cpu:
        t = {r["threads"]: fl(r["total_ms"]) for r in cpu}
        top = max(t, key=lambda k: fl(k) or 0)
        one, last = t.get("1"), t[top]
        summary.append(["CPU frame, Sibenik {} photons, 1 -> {} threads".format(cpu[0]["photons"], top),
                        "{} -> {} ms ({})".format(num(one), num(last),
                                                  "{:.1f}x".format(one / last) if one and last else "-")])
    if cmp:
        summary.append(["GPU vs CPU image (Sibenik)", "PSNR {} dB".format(num(cmp.get("psnr"), "{:.2f}"))])
    bad = [s["step"] + " " + s["status"] for s in steps if s["status"] != "ok"]
    summary.append(["steps", "{} of {} ok{}".format(len(steps) - len(bad), len(steps),
                                                    "; " + ", ".join(bad) if bad else "")])
    md.insert(4, "## Summary\n\n" + table(["", ""], summary) + "\n")

    with open(os.path.join(a.out, base + ".md"), "w", encoding="utf-8") as f:
        f.write("\n".join(md) + "\n")
    if frame_rows:
        fields = ["suite_step"] + [k for k in frame_rows[0] if k != "suite_step"]
        with open(os.path.join(a.out, base + ".csv"), "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, fieldnames=fields, extrasaction="ignore")
            w.writeheader()
            w.writerows(frame_rows)
    print("report: {}/{}.md{}".format(a.out, base, " and .csv" if frame_rows else ""))
    width = max(len(r[0]) for r in summary)
    for k, v in summary:
        print("  {:<{}}  {}".format(k, width, v))
    return 0


def fallback(argv, err):
    """Where the report itself fails (an unexpected CSV, say): the steps, the error and the frame CSVs as
    they are, so that the measurements are not lost."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--work", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--device", default="unknown")
    a, _ = ap.parse_known_args(argv)
    base = os.path.join(a.out, "{}-{}".format(slug(a.device), datetime.date.today().isoformat()))
    md = ["# photongi on {} (the report failed)".format(a.device), "", code(err), ""]
    for name in ("steps.csv", "tests.csv", "frame-sibenik.csv", "frame-crytek-sponza-paper.csv", "cpu-scaling.csv"):
        md += ["## " + name, code(read(os.path.join(a.work, name)), 20000), ""]
    with open(base + ".md", "w", encoding="utf-8") as f:
        f.write("\n".join(md) + "\n")
    with open(base + ".csv", "w", encoding="utf-8") as f:
        f.write(read(os.path.join(a.work, "frame-sibenik.csv")))
    print("report FAILED ({}); the raw tables are in {}.md".format(err.strip().splitlines()[-1], base))
    return 1


if __name__ == "__main__":
    try:
        sys.exit(main())
    except Exception:  # noqa: BLE001 (any failure: keep what was measured)
        import traceback
        sys.exit(fallback(sys.argv[1:], traceback.format_exc()))
