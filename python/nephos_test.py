#!/usr/bin/python3
"""The Python module against the command line: the same engine, the same numbers, bit for bit.

Run by CTest: nephos_test.py NEPHOS_BINARY, with PYTHONPATH holding the built module.
"""
import os
import subprocess
import sys
import tempfile
import unittest
from pathlib import Path

import numpy as np

import nephos

NEPHOS = None
SAMPLE = Path(os.environ.get("NEPHOS_DATA_DIR", Path(__file__).resolve().parent.parent / "data")) / \
    "gfs_20110110_12z_f120_2p5deg.grib2"


def cli(*args):
    r = subprocess.run([NEPHOS, "-q", *map(str, args)], capture_output=True, text=True, timeout=300)
    if r.returncode != 0:
        raise AssertionError(r.stderr)


def netcdf(path):
    import netCDF4
    ds = netCDF4.Dataset(path)
    ds.set_auto_mask(False)  # NaN where there is no value, as the module returns
    return ds


class Weather(unittest.TestCase):
    def test_reads_the_sample_and_its_masks_equal_the_cli(self):
        w = nephos.Weather(str(SAMPLE))
        self.assertEqual(w.shape, (73, 144))
        self.assertEqual(w.valid_time, "2011-01-15T12:00:00Z")
        self.assertEqual(w.latitudes[0], -90.0)
        self.assertEqual(w.longitudes[-1], 357.5)
        masks = w.masks()
        with tempfile.TemporaryDirectory() as d:
            cli("masks", "--weather", SAMPLE, "--out", d)
            ref = netcdf(Path(d) / "masks.nc")
            self.assertEqual(sorted(masks), sorted(["low_stratus", "low_cumulus", "altostratus", "cirrus"]))
            for name, a in masks.items():
                self.assertEqual(a.shape, (73, 144))
                self.assertTrue(np.array_equal(a, ref[name][:]), name)

    def test_errors_are_python_exceptions_naming_what_is_wrong(self):
        with self.assertRaisesRegex(OSError, "/nonexistent/gfs.grib2"):
            nephos.Weather("/nonexistent/gfs.grib2")
        with tempfile.TemporaryDirectory() as d:
            p = Path(d) / "notes.txt"
            p.write_text("temperature 12 C\n")
            with self.assertRaisesRegex(ValueError, "not a GRIB file"):
                nephos.Weather(str(p))
            with self.assertRaisesRegex(ValueError, "valid times: 2011-01-15T12:00:00Z"):
                nephos.Weather(str(SAMPLE), valid_time="2011-01-16T00:00:00Z")
            bad = Path(d) / "bad.toml"
            bad.write_text("[masks]\nno_such_key = 1\n")
            with self.assertRaisesRegex(ValueError, "no_such_key"):
                nephos.Weather(str(SAMPLE)).masks(config=str(bad))


class Render(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.weather = nephos.Weather(str(SAMPLE))

    def test_render_equals_the_cli_bit_for_bit(self):
        # The same scene and view through both doors, with the wind advanced 3 h as
        # --advance-hours does: every array of render.nc, value for value.
        args = dict(sensor="leo:45,-30,700,30", size=(96, 80), bands=["vis", "lwir"], steps=15)
        scene = nephos.Scene(self.weather, types=["low_stratus", "cirrus"], texture=64, seed=7)
        scene.advance(3.0)
        img = scene.render(**args)
        with tempfile.TemporaryDirectory() as d:
            cli("--seed", 7, "render", "--weather", SAMPLE, "--sensor", args["sensor"], "--size", "96x80",
                "--types", "low_stratus,cirrus", "--texture", 64, "--bands", "vis,lwir", "--steps", 15,
                "--advance-hours", 3, "--out", d)
            ref = netcdf(Path(d) / "render.nc")
            for name in ("radiance_vis", "radiance_lwir", "brightness_temperature_lwir", "cloud_top_altitude",
                         "cloud_optical_depth", "cloud_fraction", "cloud_type", "latitude", "longitude"):
                self.assertEqual(img[name].shape, (80, 96), name)
                self.assertTrue(np.array_equal(img[name], ref[name][:], equal_nan=name != "cloud_type"), name)
        self.assertGreater(np.count_nonzero(img["cloud_type"] >= 0), 1000)  # the view holds clouds (3280 of 7680)
        self.assertEqual(img["time"], "2011-01-15T12:00:00Z")
        self.assertEqual(sorted(img["seconds_per_type"]), ["cirrus", "low_stratus"])

    def test_one_scene_many_views_and_thread_counts(self):
        # A scene is built once and rendered from any sensor; the threads change nothing.
        scene = nephos.Scene(self.weather, types=["altostratus"], texture=32, seed=2)
        self.assertEqual(scene.types, ["altostratus"])
        nephos.set_threads(1)
        a = scene.render(size=(64, 64), bands=["nir"])
        nephos.set_threads(2)
        b = scene.render(size=(64, 64), bands=["nir"])
        nephos.set_threads(0)
        self.assertTrue(np.array_equal(a["radiance_nir"], b["radiance_nir"]))
        self.assertNotIn("brightness_temperature_nir", a)  # a solar band
        leo = scene.render(sensor="leo:0,-75,700,10", size=(32, 32), bands=["nir"])
        self.assertEqual(leo["radiance_nir"].shape, (32, 32))
        # Two Python threads rendering the scene at once (the GIL is released): the same arrays.
        import threading
        out = {}
        views = {"geo": dict(size=(64, 64), bands=["nir"]),
                 "leo": dict(sensor="leo:0,-75,700,10", size=(32, 32), bands=["nir"])}
        threads = [threading.Thread(target=lambda k=k, v=v: out.__setitem__(k, scene.render(**v))) for k, v in
                   views.items()]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        self.assertTrue(np.array_equal(out["geo"]["radiance_nir"], a["radiance_nir"]))
        self.assertTrue(np.array_equal(out["leo"]["radiance_nir"], leo["radiance_nir"]))
        # The Earth's disc from GEO: space (NaN latitude) in the corners, the sub-satellite
        # point in the middle.
        self.assertTrue(np.isnan(a["latitude"][0, 0]))
        self.assertLess(abs(a["longitude"][32, 32] + 75.2), 3)

    def test_bad_arguments_name_the_keyword(self):
        with self.assertRaisesRegex(ValueError, "texture"):
            nephos.Scene(self.weather, texture=100)
        with self.assertRaisesRegex(ValueError, "no_such_type|unknown cloud type"):
            nephos.Scene(self.weather, types=["no_such_type"])
        scene = nephos.Scene(self.weather, types=["cirrus"], texture=16)
        for kwargs, needle in ((dict(size=(0, 10)), "size"), (dict(steps=0), "steps"), (dict(samples=3), "samples"),
                               (dict(bands=["uv"]), "uv"), (dict(sensor="geo:east"), "geo"),
                               (dict(time="noon"), "noon")):
            with self.assertRaisesRegex(ValueError, needle, msg=str(kwargs)):
                scene.render(size=kwargs.pop("size", (8, 8)), **kwargs)
        with self.assertRaisesRegex(ValueError, "hours"):
            scene.advance(1e6)


if __name__ == "__main__":
    NEPHOS = sys.argv.pop(1)
    unittest.main(verbosity=2)
