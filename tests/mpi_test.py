#!/usr/bin/python3
"""`nephos lbm` under `mpirun -np 2` must give bit-identical fields to one process.

Run by CTest: mpi_test.py NEPHOS_BINARY
"""
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

NEPHOS = None


class Mpi(unittest.TestCase):
    def test_two_processes_bit_identical(self):
        import netCDF4
        import numpy as np
        args = ["lbm", "--grid", "24x20x16", "--iterations", "12", "--size", "64x48"]
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            one = subprocess.run([NEPHOS, "-q", *args, "--out", str(d / "one")], capture_output=True, text=True, timeout=300)
            self.assertEqual(one.returncode, 0, one.stderr)
            two = subprocess.run(["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", "2", NEPHOS, "-q", *args,
                                  "--out", str(d / "two")], capture_output=True, text=True, timeout=300)
            self.assertEqual(two.returncode, 0, two.stdout + two.stderr)
            a, b = netCDF4.Dataset(d / "one" / "lbm.nc"), netCDF4.Dataset(d / "two" / "lbm.nc")
            for v in ("vapour_density", "temperature", "percolated_density", "light"):
                self.assertTrue(np.array_equal(a[v][:], b[v][:]), v)
            self.assertEqual((d / "one" / "render.png").read_bytes(), (d / "two" / "render.png").read_bytes())


if __name__ == "__main__":
    NEPHOS = sys.argv.pop(1)
    unittest.main(verbosity=2)
