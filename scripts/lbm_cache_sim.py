#!/usr/bin/python3
"""Where the water model's pass 2 finds its populations: an L2 cache simulation.

The fused step (src/nephos/lbm/water_model.cpp, fused_step_impl) runs a wavefront over z in
blocks of rows: per plane, pass 1 pulls the populations of plane z + 1 for the block's rows and
one halo row on each side (to sum the densities), then pass 2 pulls those of plane z again (to
collide). Pass 2 is fast only if what pass 1 pulled one plane earlier is still in L2. This
script replays one thread's pulls, cache line by cache line, through a set-associative LRU
cache and prints pass 2's hit rate for a given direction stride padding: the model behind
Grid3::direction_stride() (docs/lbm.md). Pure Python, no dependencies; well under a second per case.

  /usr/bin/python3 scripts/lbm_cache_sim.py            # the default cases
  /usr/bin/python3 scripts/lbm_cache_sim.py 2 864 16   # bytes per value, padding, block rows
"""
import sys
from collections import OrderedDict

# D3Q19 velocities (src/nephos/lbm/d3q19.hpp): only y and z matter for which rows are pulled.
CY = [0, 0, 0, 1, -1, 0, 0, 1, -1, 0, 0, 1, -1, 1, -1, -1, 1, 0, 0]
CZ = [0, 0, 0, 0, 0, 1, -1, 0, 0, 1, -1, 1, -1, -1, 1, 0, 0, -1, 1]


def pass2_hit_rate(value_bytes, pad, block, n=128, planes=12, sets=1024, ways=8, round_to=32768, line=64):
    """L2 hit rate of pass 2's pulls (Zen 3 L2: 512 KiB, 8-way, 1024 sets of 64 B lines)."""
    cells = n ** 3
    stride = (cells + round_to - 1) // round_to * round_to + pad
    bases = [0, 1 << 31]  # the two components: separate allocations, 2 MiB aligned
    cache = [OrderedDict() for _ in range(sets)]
    hits = accesses = 0

    def pull_row(component, y, z, counted):
        nonlocal hits, accesses
        for i in range(19):
            sy, sz = (y - CY[i]) % n, z - CZ[i]
            if not 0 <= sz < n:
                continue  # the wall: bounce-back reads the cell's own row
            start = bases[component] + (i * stride + (sz * n + sy) * n) * value_bytes
            for address in range(start, start + n * value_bytes, line):
                tag = address // line
                s = cache[tag % sets]
                hit = tag in s
                if hit:
                    s.move_to_end(tag)
                else:
                    s[tag] = True
                    if len(s) > ways:
                        s.popitem(last=False)
                if counted:
                    hits += hit
                    accesses += 1

    y0, y1 = 16, 16 + block
    for z in range(30, 30 + planes):
        for y in range(y0 - 1, y1 + 1):  # pass 1 of plane z + 1, with halo rows
            for c in (0, 1):
                pull_row(c, y, z + 1, False)
        for y in range(y0, y1):  # pass 2 of plane z
            for c in (0, 1):
                pull_row(c, y, z, True)
    return hits / accesses


def main():
    cases = [(4, 32, 16, 2048), (2, 32, 16, 2048), (4, 864, 16, 32768), (2, 864, 16, 32768), (4, 864, 8, 32768)]
    if len(sys.argv) == 4:
        cases = [(int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3]), 32768)]
    for value_bytes, pad, block, round_to in cases:
        rate = pass2_hit_rate(value_bytes, pad, block, round_to=round_to)
        print(f"{'FP32' if value_bytes == 4 else 'FP16'}, padding {pad}, rounded to {round_to}, "
              f"{block}-row blocks: pass 2 L2 hit rate {rate:.3f}")


if __name__ == "__main__":
    main()
