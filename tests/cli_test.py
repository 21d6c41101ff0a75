#!/usr/bin/python3
"""End-to-end tests of the nephos command line: what a user types, what they get back.

Run by CTest with the path of the built binary: cli_test.py NEPHOS_BINARY
Uses Debian's python3 (numpy, xarray, netCDF4) and ecCodes' grib_copy.
"""
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

NEPHOS = None
SOURCE = Path(__file__).resolve().parent.parent
SAMPLE = SOURCE / "data" / "gfs_20110110_12z_f120_2p5deg.grib2"


def run(*args, cwd=None):
    return subprocess.run([NEPHOS, *map(str, args)], capture_output=True, text=True, cwd=cwd, timeout=300)


class Info(unittest.TestCase):
    def test_describes_the_embedded_sample(self):
        r = run("info", SAMPLE)
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertIn("regular_ll 144 x 73", r.stdout)
        self.assertIn("valid time     2011-01-15T12:00:00Z", r.stdout)
        self.assertIn("forecast step  120 h", r.stdout)
        self.assertIn("missing at 20)", r.stdout)  # GFS has no r at 20 hPa
        self.assertRegex(r.stdout, r"weather masks \(nephos masks\)\s+yes")

    def assert_input_error(self, r, *needles):
        self.assertEqual(r.returncode, 2, r.stdout + r.stderr)
        lines = r.stderr.strip().splitlines()
        self.assertEqual(len(lines), 1, r.stderr)  # one line, no stack trace
        for n in needles:
            self.assertIn(n, lines[0])

    def test_missing_file(self):
        self.assert_input_error(run("info", "/nonexistent/gfs.grib2"), "/nonexistent/gfs.grib2", "no such file")

    def test_not_grib(self):
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "notes.txt"
            p.write_text("temperature 12 C\n")
            self.assert_input_error(run("info", p), str(p), "not a GRIB file")

    def test_surface_only_grib(self):
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "surface.grib2"
            subprocess.run(["grib_copy", "-w", "typeOfLevel=surface", SAMPLE, p], check=True)
            self.assert_input_error(run("info", p), str(p), "no pressure-level fields", "orog/surface")


class Masks(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = tempfile.TemporaryDirectory()
        cls.out = Path(cls.tmp.name) / "out"
        cls.result = run("--threads", "2", "masks", "--out", cls.out)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_writes_pngs_and_netcdf_and_nothing_else(self):
        self.assertEqual(self.result.returncode, 0, self.result.stderr)
        names = sorted(p.name for p in self.out.iterdir())
        self.assertEqual(names, ["altostratus.png", "cirrus.png", "low_cumulus.png", "low_stratus.png", "masks.nc"])
        self.assertIn("correlation", self.result.stdout)

    def test_netcdf_is_cf_and_readable_by_xarray(self):
        import numpy as np
        import xarray as xr
        ds = xr.open_dataset(self.out / "masks.nc")
        self.assertEqual(ds.attrs["Conventions"], "CF-1.8")
        self.assertEqual(ds["latitude"].attrs["units"], "degrees_north")
        self.assertEqual(ds["longitude"].attrs["units"], "degrees_east")
        for v in ("low_stratus", "low_cumulus", "altostratus", "cirrus"):
            self.assertEqual(ds[v].dims, ("latitude", "longitude"))
            self.assertEqual(ds[v].attrs["units"], "1")
            self.assertIn("long_name", ds[v].attrs)
            a = ds[v].values
            self.assertTrue(np.all((a >= 0) & (a <= 1)), v)
        self.assertEqual(str(ds["time"].values)[:19], "2011-01-15T12:00:00")
        # A hand-checked cell: 15N 245E is under GFS's 99 % high cloud (see masks_test.cpp).
        self.assertGreater(float(ds["cirrus"].sel(latitude=15, longitude=245)), 0.5)
        r = subprocess.run(["ncdump", "-h", self.out / "masks.nc"], capture_output=True, text=True)
        self.assertEqual(r.returncode, 0, r.stderr)

    def test_bit_identical_with_one_thread(self):
        import netCDF4
        import numpy as np
        with tempfile.TemporaryDirectory() as d:
            r = run("--threads", "1", "masks", "--out", d)
            self.assertEqual(r.returncode, 0, r.stderr)
            a, b = netCDF4.Dataset(self.out / "masks.nc"), netCDF4.Dataset(Path(d) / "masks.nc")
            for v in ("low_stratus", "low_cumulus", "altostratus", "cirrus"):
                self.assertTrue(np.array_equal(a[v][:], b[v][:]), v)
            self.assertEqual((self.out / "cirrus.png").read_bytes(), (Path(d) / "cirrus.png").read_bytes())

    def test_bad_weather_writes_nothing(self):
        with tempfile.TemporaryDirectory() as d:
            bad = Path(d) / "bad.grib2"
            bad.write_bytes(b"\x00" * 100)
            out = Path(d) / "out"
            r = run("masks", "--weather", bad, "--out", out)
            self.assertEqual(r.returncode, 2)
            self.assertIn("not a GRIB file", r.stderr)
            self.assertFalse(out.exists() and any(out.iterdir()))

    def test_unknown_config_key_is_an_error_with_its_line(self):
        with tempfile.TemporaryDirectory() as d:
            cfg = Path(d) / "m.toml"
            cfg.write_text("[masks.cirrus]\nband_bottom_m = 7000\nbogus_threshold = 3\n")
            out = Path(d) / "out"
            r = run("masks", "--config", cfg, "--out", out)
            self.assertEqual(r.returncode, 2)
            self.assertIn(f"{cfg}:3", r.stderr)
            self.assertIn("masks.cirrus.bogus_threshold", r.stderr)
            self.assertFalse(out.exists())

    def test_synthetic_weather(self):
        with tempfile.TemporaryDirectory() as d:
            r = run("--seed", "7", "masks", "--synthetic", "--out", d)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertTrue((Path(d) / "masks.nc").exists())


class Usage(unittest.TestCase):
    def test_help_and_bad_option(self):
        self.assertEqual(run("--help").returncode, 0)
        r = run("masks", "--no-such-option")
        self.assertEqual(r.returncode, 2)
        self.assertEqual(run("--threads", "-3", "masks").returncode, 2)


if __name__ == "__main__":
    NEPHOS = sys.argv.pop(1)
    unittest.main(verbosity=2)
