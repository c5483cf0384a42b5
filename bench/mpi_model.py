#!/usr/bin/env python3
"""The efficiency model of docs/distributed.md: progressive photon mapping on P nodes with
photongi-mpi's flat reduction to rank 0, and with a tile-split reduction (each rank reduces one
tile of the image). Prints the table of docs/distributed.md; edit the figures below (frame times
on a node, network, frames) for another machine.
  usage: bench/mpi_model.py [FRAMES]"""
import math
import sys

B = 4  # PGI_PROGRESSIVE_BLOCK
N = int(sys.argv[1]) if len(sys.argv) > 1 else 16384
T0 = 2.0  # start, MPI_Init, scene load (s)
M = 10e9  # memory bandwidth for the adds (bytes/s)
SPEEDUP_16 = 6.4  # a 16-core node against the 2 cores measured: 8x cores at 80 % (assumed)
# Sibenik, 200k photons, automatic radius: seconds a frame measured with 2 threads
IMAGES = {"1080p": (1920 * 1080, 2.074), "4K": (3840 * 2160, 6.011)}
NETWORKS = {"10 GbE": 1.1e9, "100 Gb IB": 11e9}
NODES = (64, 128, 256, 512, 1024)


def efficiency(p, pixels, tf, bw, tile):
    s = 24 * pixels  # a block sum: 3 doubles a pixel
    blocks = N / B
    comp = math.ceil(blocks / p) * B * tf
    if not tile:
        t = T0 + tf + max(comp, blocks * (s / bw + 3 * s / M))
    else:
        merge = blocks * (3 * s / p) / M
        comm = blocks * (s / p) / bw + math.ceil(blocks / p) * s / bw
        t = T0 + tf + max(comp + merge, comm)
    return N * tf / (p * t)


print(f"N = {N} frames, B = {B}, t0 = {T0} s")
print("| image | network | reduction | " + " | ".join(f"{p} nodes" if p == NODES[0] else str(p) for p in NODES) + " |")
print("|---|---|---|" + "---|" * len(NODES))
for name, (px, tf2) in IMAGES.items():
    tf = tf2 / SPEEDUP_16
    for net, bw in NETWORKS.items():
        for tile in (False, True):
            row = " | ".join(f"{100 * efficiency(p, px, tf, bw, tile):.0f} %" for p in NODES)
            print(f"| {name} | {net} | {'tile-split' if tile else 'flat to rank 0'} | {row} |")
for name, (px, tf2) in IMAGES.items():
    tf, s = tf2 / SPEEDUP_16, 24 * px
    for net, bw in NETWORKS.items():
        tau = s / bw + 3 * s / M
        print(f"{name} {net}: S = {s / 1e6:.0f} MB, tau = {1e3 * tau:.0f} ms, t_f = {tf:.2f} s, P* = {B * tf / tau:.0f}")
