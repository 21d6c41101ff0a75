#!/usr/bin/python3
"""`nephos lbm` under `mpirun -np 2` (and 3) must give bit-identical fields to one process.

Run by CTest: mpi_test.py NEPHOS_BINARY
"""
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

NEPHOS = None


class Mpi(unittest.TestCase):
    def test_two_and_three_processes_bit_identical(self):
        # Every stage runs on slabs along y: the water model, the percolation (on the refined
        # rows) and the lighting (the default sun's light crosses the cuts), each exchanging
        # halo rows; rank 0 gathers the fields. Three processes cut the 20 rows 6 + 7 + 7.
        import netCDF4
        import numpy as np
        args = ["lbm", "--grid", "24x20x16", "--iterations", "12", "--size", "64x48"]
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            one = subprocess.run([NEPHOS, "-q", *args, "--out", str(d / "one")], capture_output=True, text=True, timeout=300)
            self.assertEqual(one.returncode, 0, one.stderr)
            a = netCDF4.Dataset(d / "one" / "lbm.nc")
            for n in ("2", "3"):
                r = subprocess.run(["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", n, NEPHOS, "-q", *args,
                                    "--out", str(d / n)], capture_output=True, text=True, timeout=300)
                self.assertEqual(r.returncode, 0, r.stdout + r.stderr)
                b = netCDF4.Dataset(d / n / "lbm.nc")
                for v in ("vapour_density", "temperature", "percolated_density", "light"):
                    self.assertTrue(np.array_equal(a[v][:], b[v][:]), f"{n} processes: {v}")
                self.assertEqual((d / "one" / "render.png").read_bytes(), (d / n / "render.png").read_bytes())
                # The same step counts: the stages' stopping rules see the whole grid.
                self.assertEqual([l.split(" in ")[0] for l in one.stdout.splitlines()[1:3]],
                                 [l.split(" in ")[0] for l in r.stdout.splitlines()[1:3]], n)

    def test_checkpoints_resume_across_process_counts(self):
        # Checkpoints are one file whatever the process count: an MPI run stopped at step 6 and
        # resumed on 2 or on 1 process, and a 1-process checkpoint resumed on 2 processes, all
        # end bit-identical to an uninterrupted 12-step run.
        import netCDF4
        import numpy as np
        mpirun = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", "2", NEPHOS, "-q"]
        args = ["lbm", "--grid", "24x20x16", "--size", "64x48", "--percolation", "0"]

        def run(cmd, *extra):
            r = subprocess.run([*cmd, *args, *extra], capture_output=True, text=True, timeout=300)
            self.assertEqual(r.returncode, 0, r.stdout + r.stderr)

        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            run([NEPHOS, "-q"], "--iterations", "12", "--out", str(d / "straight"))
            run(mpirun, "--iterations", "6", "--checkpoint-every", "6", "--out", str(d / "mpi6"))
            run([NEPHOS, "-q"], "--iterations", "6", "--checkpoint-every", "6", "--out", str(d / "one6"))
            self.assertEqual((d / "mpi6" / "checkpoint.bin").read_bytes(), (d / "one6" / "checkpoint.bin").read_bytes())
            run(mpirun, "--iterations", "12", "--resume", str(d / "mpi6" / "checkpoint.bin"), "--out", str(d / "mm"))
            run([NEPHOS, "-q"], "--iterations", "12", "--resume", str(d / "mpi6" / "checkpoint.bin"), "--out",
                str(d / "m1"))
            run(mpirun, "--iterations", "12", "--resume", str(d / "one6" / "checkpoint.bin"), "--out", str(d / "1m"))
            # A truncated checkpoint stops every rank with a message (no rank left waiting).
            (d / "cut.bin").write_bytes((d / "one6" / "checkpoint.bin").read_bytes()[:900000])
            cut = subprocess.run([*mpirun, *args, "--iterations", "12", "--resume", str(d / "cut.bin"), "--out",
                                  str(d / "cut")], capture_output=True, text=True, timeout=120)
            self.assertNotEqual(cut.returncode, 0)
            self.assertIn("truncated checkpoint", cut.stderr)
            ref = netCDF4.Dataset(d / "straight" / "lbm.nc")
            for case in ("mm", "m1", "1m"):
                got = netCDF4.Dataset(d / case / "lbm.nc")
                for v in ("vapour_density", "temperature", "light"):
                    self.assertTrue(np.array_equal(ref[v][:], got[v][:]), f"{case}: {v}")

    def test_bad_density_stops_every_rank_with_a_checkpoint(self):
        # An unstable configuration (buoyancy 1000) blows up within 10 steps: every rank stops
        # with the message naming step and cell, exit code 2, and the failure checkpoint equals
        # the single-process one byte for byte.
        with tempfile.TemporaryDirectory() as d:
            d = Path(d)
            (d / "bad.toml").write_text("[water]\nbuoyancy = 1000.0\n")
            args = ["lbm", "--grid", "24x20x16", "--iterations", "30", "--percolation", "0", "--config",
                    str(d / "bad.toml")]
            one = subprocess.run([NEPHOS, "-q", *args, "--out", str(d / "one")], capture_output=True, text=True,
                                 timeout=300)
            two = subprocess.run(["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", "2", NEPHOS, "-q", *args,
                                  "--out", str(d / "two")], capture_output=True, text=True, timeout=300)
            for r in (one, two):
                self.assertNotEqual(r.returncode, 0)
                self.assertRegex(r.stderr, r"step 10: .* at cell \(x=\d+, y=\d+, z=\d+\); state saved")
            self.assertEqual((d / "one" / "checkpoint_failed.bin").read_bytes(),
                             (d / "two" / "checkpoint_failed.bin").read_bytes())
            self.assertFalse((d / "two" / "lbm.nc").exists())
            # One whole line per rank, those of ranks other than 0 naming theirs.
            lines = [l for l in two.stderr.splitlines() if "error" in l]
            self.assertEqual(sum(l.startswith("nephos: error: ") for l in lines), 1, two.stderr)
            self.assertEqual(sum(l.startswith("nephos (rank 1 of 2): error: ") for l in lines), 1, two.stderr)


if __name__ == "__main__":
    NEPHOS = sys.argv.pop(1)
    unittest.main(verbosity=2)
