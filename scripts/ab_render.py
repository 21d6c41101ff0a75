#!/usr/bin/python3
"""Whole-render A/B of two builds of the Python module in one process (docs/PERFORMANCE.md, noise).

Loads build A's and build B's `nephos` extension side by side, builds one scene with each, and
renders them in interleaved pairs whose order alternates: a slow spell of the VM slows both
renders of a pair alike. Prints each pair's times [s] and B/A ratio, then the median ratio.

Usage: scripts/ab_render.py A_MODULE_DIR B_MODULE_DIR [--pairs N] [--abi-step N | --table3 STEPS]
  --abi-step N   the GOES-East fixed-grid full disc coarsened N times, bands 7-16, every type (default 4)
  --table3 STEPS one low_cumulus shell, GEO disc 2000^2, STEPS march steps: the shell's tracing time
"""
import argparse
import glob
import importlib.machinery
import importlib.util
import statistics
import time

THERMAL = ["mwir", "wv62", "wv69", "wv73", "ir85", "o3", "lwir", "lwir11", "lwir12", "co2"]
WEATHER = "data/gfs_20110110_12z_f120_2p5deg.grib2"


def load(directory):
    """The nephos extension module built in `directory`, under its own name, not in sys.modules."""
    path = glob.glob(directory + "/nephos*.so")[0]
    loader = importlib.machinery.ExtensionFileLoader("nephos", path)
    module = importlib.util.module_from_spec(importlib.util.spec_from_file_location("nephos", path, loader=loader))
    loader.exec_module(module)
    return module


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("a"), ap.add_argument("b")
    ap.add_argument("--pairs", type=int, default=10)
    ap.add_argument("--abi-step", type=int, default=4)
    ap.add_argument("--table3", type=int, default=0, metavar="STEPS")
    o = ap.parse_args()

    def scene(m):
        types = ["low_cumulus"] if o.table3 else None
        return m.Scene(m.Weather(WEATHER), types=types, texture=256)

    def render(s):
        if o.table3:
            d = s.render(sensor="geo:-75.2", size=(2000, 2000), steps=o.table3, as_dict=True)
            return dict(d["seconds_per_type"])["low_cumulus"]
        t = time.perf_counter()
        s.render(sensor="abi:east", abi_step=o.abi_step, bands=THERMAL, as_dict=True)
        return time.perf_counter() - t

    sa, sb = scene(load(o.a)), scene(load(o.b))
    render(sa), render(sb)  # warm-up: tables built on first use, caches
    ratios = []
    for k in range(o.pairs):
        if k % 2 == 0:
            ta = render(sa)
            tb = render(sb)
        else:
            tb = render(sb)
            ta = render(sa)
        ratios.append(tb / ta)
        print(f"A {ta:.3f} s  B {tb:.3f} s  B/A {tb / ta:.3f}", flush=True)
    print(f"median B/A over {o.pairs} pairs: {statistics.median(ratios):.3f} ({min(ratios):.3f}-{max(ratios):.3f})")


if __name__ == "__main__":
    main()
