#!/usr/bin/python3
"""Damaged copies of a GRIB file through nephos: every run must end as the error contract says.

Each copy of WEATHER is damaged one way, chosen at random (Python's seeded generator, so a run
repeats), and given to `nephos info`, `masks` or `render` (64x64, 32^3 textures). A run passes if
it exits 0, or exits 2 with one error line (`nephos: error: ...`, after any `[warning]` lines),
within the time limit. A failing copy is kept in OUT with the way it was damaged.

Damage:
  flip    1, 4 or 32 bits flipped anywhere in the file (mostly packed values)
  header  1-3 bytes flipped or overwritten within 260 bytes of a message's start (its sections'
          lengths, templates, times and packing parameters)
  cut     the file cut short at a random byte
  zero    up to 4 KiB zeroed at a random byte
  splice  200 bytes of the file inserted at a random byte

Usage: scripts/fuzz_grib.py NEPHOS [--weather FILE] [--runs N] [--seed S] [--commands info,masks,render]
                            [--damage flip,header,cut,zero,splice] [--timeout SECONDS] [--out DIR]
"""
import argparse
import random
import subprocess
import sys
import tempfile
from pathlib import Path

SOURCE = Path(__file__).resolve().parent.parent


def message_starts(data):
    starts, at = [], data.find(b"GRIB")
    while at >= 0:
        starts.append(at)
        at = data.find(b"GRIB", at + 4)
    return starts


def damage(data, how, starts, rng):
    b = bytearray(data)
    if how == "flip":
        for _ in range(rng.choice([1, 4, 32])):
            i = rng.randrange(len(b))
            b[i] ^= 1 << rng.randrange(8)
    elif how == "header":
        for _ in range(rng.choice([1, 2, 3])):
            i = min(len(b) - 1, rng.choice(starts) + rng.randrange(260))
            b[i] = b[i] ^ (1 << rng.randrange(8)) if rng.random() < 0.5 else rng.randrange(256)
    elif how == "cut":
        b = b[:rng.randrange(len(b))]
    elif how == "zero":
        i = rng.randrange(len(b))
        n = min(len(b) - i, rng.randrange(1, 4097))
        b[i:i + n] = bytes(n)
    elif how == "splice":
        i, j = rng.randrange(len(b)), rng.randrange(len(b))
        b[i:i] = data[j:j + 200]
    return bytes(b)


def passes(returncode, stderr):
    """Exit 0, or exit 2 with one error line after any warnings."""
    if returncode == 0:
        return True
    lines = [l for l in stderr.strip().splitlines() if not l.startswith("[warning]")]
    return returncode == 2 and len(lines) == 1 and lines[0].startswith("nephos: error: ")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("nephos")
    ap.add_argument("--weather", default=str(SOURCE / "data" / "gfs_20110110_12z_f120_2p5deg.grib2"))
    ap.add_argument("--runs", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--commands", default="info,masks,render")
    ap.add_argument("--damage", default="flip,header,cut,zero,splice")
    ap.add_argument("--timeout", type=float, default=120, help="seconds a run may take before it counts as a hang")
    ap.add_argument("--out", default="fuzz-failures")
    o = ap.parse_args()
    data = Path(o.weather).read_bytes()
    starts = message_starts(data)
    rng = random.Random(o.seed)
    commands, kinds = o.commands.split(","), o.damage.split(",")
    failures, outcomes = 0, {}
    with tempfile.TemporaryDirectory() as tmp:
        copy, out = Path(tmp) / "damaged.grib2", Path(tmp) / "out"
        for k in range(o.runs):
            how, command = rng.choice(kinds), rng.choice(commands)
            copy.write_bytes(damage(data, how, starts, rng))
            args = {"info": ["info", copy], "masks": ["masks", "--weather", copy, "--out", out],
                    "render": ["render", "--weather", copy, "--size", "64x64", "--texture", "32", "--out", out]}
            try:
                r = subprocess.run([o.nephos, "-q", *args[command]], capture_output=True, text=True,
                                   timeout=o.timeout)
                code, ok, err = r.returncode, passes(r.returncode, r.stderr), r.stderr.strip()
            except subprocess.TimeoutExpired:
                code, ok, err = "hang", False, f"no end within {o.timeout:g} s"
            outcomes[code] = outcomes.get(code, 0) + 1
            if not ok:
                failures += 1
                Path(o.out).mkdir(parents=True, exist_ok=True)
                keep = Path(o.out) / f"seed{o.seed}_run{k}_{how}_{command}.grib2"
                keep.write_bytes(copy.read_bytes())
                print(f"FAIL run {k}: {how}, {command}: exit {code}: {err[-300:]} (kept as {keep})", flush=True)
    print(f"{o.runs} runs, {failures} failed; outcomes by exit code: "
          + ", ".join(f"{c}: {n}" for c, n in sorted(outcomes.items(), key=str)))
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
