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

    def test_run_masks_writes_what_nephos_masks_writes(self):
        # One request, two front ends: masks.nc and the four PNGs of `nephos masks` with the same
        # configuration and PNG width, byte for byte; the returned masks those of masks.nc, and
        # the cover and agreement those the command prints.
        with tempfile.TemporaryDirectory() as d:
            config = Path(d) / "masks.toml"
            config.write_text("[cloud_fraction]\nrh_critical = 0.7\n[masks]\nvertical_step_m = 250.0\n")
            py_out, cli_out = Path(d) / "py", Path(d) / "cli"
            got = nephos.run_masks(weather=str(SAMPLE), config=str(config), png_width=360, out=str(py_out))
            r = subprocess.run([NEPHOS, "-q", "masks", "--weather", str(SAMPLE), "--config", str(config),
                                "--png-width", "360", "--out", str(cli_out)], capture_output=True, text=True,
                               timeout=300)
            self.assertEqual(r.returncode, 0, r.stderr)
            names = sorted(p.name for p in cli_out.iterdir())
            self.assertEqual(names, sorted(p.name for p in py_out.iterdir()))
            self.assertEqual(len(names), 5)
            for name in names:
                self.assertEqual((py_out / name).read_bytes(), (cli_out / name).read_bytes(), name)
            ref = netcdf(cli_out / "masks.nc")
            for name, a in got["masks"].items():
                self.assertTrue(np.array_equal(a, ref[name][:]), name)
                self.assertIn(f"{name:<12} {got['cover'][name]:>10.3f}", r.stdout)
            self.assertEqual([a["layer"] for a in got["agreement"]], ["low", "middle", "high"])
            for a in got["agreement"]:
                self.assertIn(f"{a['gfs_cover']:>10.3f} {a['correlation']:>12.3f}", r.stdout)
            self.assertEqual(got["valid_time"], "2011-01-15T12:00:00Z")
            for kwargs, needle in ((dict(png_width=8), "'png_width'"), (dict(weather_time="x"), "'weather_time'"),
                                   (dict(synthetic=True, weather_time="2011-01-15T12:00:00Z"), "'weather_time'")):
                with self.assertRaisesRegex(ValueError, needle, msg=str(kwargs)):
                    nephos.run_masks(out=str(Path(d) / "never"), **kwargs)
            self.assertFalse((Path(d) / "never").exists())

    def test_pressure_level_fields_and_layer_cover(self):
        # The 500 hPa level's global mean height and temperature against the US Standard
        # Atmosphere 1976 (5574 m, 252.0 K): a real day's global means lie within ~150 m and
        # ~10 K of them (the embedded day: 5642 m, 258.3 K); levels out of order or in another
        # unit miss by kilometres or hundreds of kelvin.
        w = nephos.Weather(str(SAMPLE))
        p = w.pressure_levels_pa
        k = int(np.argmin(np.abs(p - 50000)))
        self.assertEqual(p[k], 50000)
        self.assertTrue(np.all(np.diff(p) < 0))
        gh, t = w.level_field("gh"), w.level_field("t")
        self.assertEqual(gh.shape, (len(p), 73, 144))
        area = np.cos(np.radians(w.latitudes))[:, None] * np.ones((1, 144))
        self.assertLess(abs(np.average(gh[k], weights=area) - 5574), 150)
        self.assertLess(abs(np.average(t[k], weights=area) - 252.0), 10)
        low = w.field("tcc", "lowCloudLayer")
        self.assertTrue(0 <= low.min() and low.max() <= 1)
        with self.assertRaisesRegex(ValueError, "short_name.*known: gh, t"):
            w.level_field("cloud")

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
        args = dict(sensor="leo:45,-30,700,30", size=(96, 80), bands=["vis", "lwir", "swir16", "lwir12"], steps=15)
        scene = nephos.Scene(self.weather, types=["low_stratus", "cirrus"], texture=64, seed=7)
        scene.advance(3.0)
        img = scene.render(**args)
        with tempfile.TemporaryDirectory() as d:
            cli("--seed", 7, "render", "--weather", SAMPLE, "--sensor", args["sensor"], "--size", "96x80",
                "--types", "low_stratus,cirrus", "--texture", 64, "--bands", "vis,lwir,swir16,lwir12", "--steps", 15,
                "--advance-hours", 3, "--out", d)
            ref = netcdf(Path(d) / "render.nc")
            for name in ("radiance_vis", "radiance_lwir", "brightness_temperature_lwir", "radiance_swir16",
                         "radiance_lwir12", "brightness_temperature_lwir12", "cloud_top_altitude",
                         "cloud_optical_depth", "cloud_fraction", "cloud_type", "latitude", "longitude"):
                self.assertEqual(img[name].shape, (80, 96), name)
                self.assertTrue(np.array_equal(img[name], ref[name][:], equal_nan=name != "cloud_type"), name)
        self.assertGreater(np.count_nonzero(img["cloud_type"] >= 0), 1000)  # the view holds clouds (3280 of 7680)
        self.assertEqual(img["time"], "2011-01-15T15:00:00Z")  # the valid time plus the wind's 3 h
        self.assertEqual(scene.time, img["time"])
        self.assertEqual(scene.render(**args, time="2011-01-15T06:00:00Z")["time"], "2011-01-15T06:00:00Z")
        self.assertEqual(sorted(img["seconds_per_type"]), ["cirrus", "low_stratus"])
        self.assertEqual(list(img["seconds_per_stage"]),
                         ["rays", "march", "hit_shadows", "hit_shading", "layers", "ground_shadows", "ground_and_sky",
                          "brightness_temperatures", "atmosphere", "outputs"])
        # The arrays are the renderer's own, handed over without a copy (a full disc's fields are
        # gigabytes): numpy does not own their memory, the capsule that frees it does.
        for name in ("radiance_vis", "brightness_temperature_lwir", "cloud_type", "latitude"):
            self.assertFalse(img[name].flags.owndata, name)
            self.assertIsNotNone(img[name].base, name)
            self.assertTrue(img[name].flags.writeable and img[name].flags.c_contiguous, name)

    def test_names_in_one_string_as_on_the_command_line(self):
        # bands and types also take one comma-separated string, as --bands and --types do: the
        # same scene and the same image as the lists give; "all" alone means every band.
        a = nephos.Scene(self.weather, types="low_stratus,cirrus", texture=16)
        b = nephos.Scene(self.weather, types=["low_stratus", "cirrus"], texture=16)
        self.assertEqual(a.types, ["low_stratus", "cirrus"])
        ia, ib = a.render(size=(24, 16), bands="vis,lwir"), b.render(size=(24, 16), bands=["vis", "lwir"])
        for name in ("radiance_vis", "brightness_temperature_lwir", "cloud_type"):
            self.assertTrue(np.array_equal(ia[name], ib[name], equal_nan=name != "cloud_type"), name)
        self.assertEqual(len([k for k in a.render(size=(8, 8), bands="all") if k.startswith("radiance_")]), 16)
        with self.assertRaisesRegex(ValueError, "'bands': empty list"):
            a.render(size=(8, 8), bands=",")

    def test_the_band_table(self):
        # The 16 GOES-16 ABI bands Scene.render takes, with what a sensor model needs of them.
        bands = nephos.bands()
        self.assertEqual([b["name"] for b in bands],
                         ["blue", "vis", "nir", "cirrus", "swir16", "swir22", "mwir", "wv62", "wv69", "wv73",
                          "ir85", "o3", "lwir", "lwir11", "lwir12", "co2"])
        self.assertEqual([b["abi_band"] for b in bands], list(range(1, 17)))
        self.assertEqual([b["name"] for b in bands if not b["thermal"]],
                         ["blue", "vis", "nir", "cirrus", "swir16", "swir22"])
        vis = bands[1]
        self.assertEqual((vis["centre_um"], vis["lo_um"], vis["hi_um"]), (0.64, 0.59, 0.69))
        self.assertEqual(vis["solar_irradiance_w_m2_um"], 1631.3351)  # ABI L1b esun, band 2
        self.assertIn("ABI band 2", vis["description"])

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
        # (an empty list crashed the renderer before build_scene refused it)
        with self.assertRaisesRegex(ValueError, "'types': no cloud type"):
            nephos.Scene(self.weather, types=[], texture=8)
        with self.assertRaisesRegex(ValueError, "'cirrus' is listed twice"):
            nephos.Scene(self.weather, types=["cirrus", "cirrus"], texture=8)
        with self.assertRaisesRegex(ValueError, "thread count must be 0..1024"):
            nephos.set_threads(10**6)
        scene = nephos.Scene(self.weather, types=["cirrus"], texture=16)
        # Each error names the keyword argument, never a command-line option.
        for kwargs, needle in ((dict(size=(0, 10)), "'size'"), (dict(steps=0), "'steps'"),
                               (dict(samples=3), "'samples'"), (dict(bands=["uv"]), "'bands': unknown band 'uv'"),
                               (dict(sensor="geo:east"), "'sensor'.*geo"), (dict(bands=["vis", "vis"]), "listed twice"),
                               (dict(bands=[]), "'bands': no band"), (dict(time="noon"), "'time'.*noon")):
            with self.assertRaisesRegex(ValueError, needle, msg=str(kwargs)) as caught:
                scene.render(size=kwargs.pop("size", (8, 8)), **kwargs)
            self.assertNotIn("--", str(caught.exception))
        with self.assertRaisesRegex(ValueError, "hours"):
            scene.advance(1e6)
        # Checked against the machine's memory before any work (~46 GiB asked for here).
        with self.assertRaisesRegex(MemoryError, r"'size': a 20000x20000 image with 256 rays per pixel needs about"):
            scene.render(size=(20000, 20000), samples=256)


def read_png_rgb8(path):
    """An 8-bit RGB, non-interlaced PNG (what nephos writes) as an (h, w, 3) uint8 array."""
    import struct
    import zlib
    data = Path(path).read_bytes()
    pos, idat, width, height = 8, b"", 0, 0
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            width, height, depth, colour, _, _, interlace = struct.unpack(">IIBBBBB", body)
            assert (depth, colour, interlace) == (8, 2, 0)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    raw, stride = zlib.decompress(idat), width * 3
    out = np.zeros((height, stride), dtype=np.int32)
    for y in range(height):
        f, line = raw[y * (stride + 1)], np.frombuffer(raw, np.uint8, stride, y * (stride + 1) + 1).astype(np.int32)
        up = out[y - 1] if y else np.zeros(stride, np.int32)
        if f in (0, 2):
            out[y] = (line + (up if f == 2 else 0)) & 255
        else:  # sub, average, Paeth: each byte depends on the one 3 to its left
            row = out[y]
            for x in range(stride):
                a = row[x - 3] if x >= 3 else 0
                c = up[x - 3] if x >= 3 else 0
                if f == 1:
                    pred = a
                elif f == 3:
                    pred = (a + up[x]) // 2
                else:
                    p = a + up[x] - c
                    pa, pb, pc = abs(p - a), abs(p - up[x]), abs(p - c)
                    pred = a if pa <= pb and pa <= pc else up[x] if pb <= pc else c
                row[x] = (line[x] + pred) & 255
    return out.astype(np.uint8).reshape(height, width, 3)


class RadiationAgainstGfs(unittest.TestCase):
    # scripts/validate_radiation.py at the CI's small configuration (300 x 300, 64^3 textures):
    # nephos's outgoing long-wave flux and albedo over GFS's 6-hour window, the clouds carried back
    # by the wind, against GFS's own (ulwrf, uswrf at nominalTop) on the embedded date. It
    # measures r 0.883 and bias -4.4 W m-2 (long wave, corrected to nadir as Elmer et al. 2016;
    # -7.2 as seen), r 0.805 and bias -0.000 (albedo); the
    # full configuration (800 x 800, 256^3) is in docs/VALIDATION.md. The bounds sit 0.05 below
    # the correlations (the spread between texture sizes and image sizes is of that order) and at
    # the issue's +-10 W m-2 for the bias: a regression in the radiometry (a band's solar
    # irradiance, the atmosphere's emission, the surface) moves them further. A consistency check
    # with GFS's radiation code, not a validation of realism.
    def test_top_of_atmosphere_fluxes(self):
        import json
        script = Path(__file__).resolve().parent.parent / "scripts" / "validate_radiation.py"
        with tempfile.TemporaryDirectory() as d:
            r = subprocess.run([sys.executable, str(script), str(SAMPLE), d, "--size", "300", "--texture", "64"],
                               capture_output=True, text=True, env=dict(os.environ))
            self.assertEqual(r.returncode, 0, r.stderr)
            s = json.loads((Path(d) / "summary.json").read_text())
            self.assertTrue((Path(d) / "olr.png").read_bytes().startswith(b"\x89PNG"))
        self.assertGreater(s["olr"]["correlation"], 0.825)
        self.assertLess(abs(s["olr"]["bias"]), 10.0)
        self.assertGreater(s["albedo"]["correlation"], 0.755)
        self.assertLess(abs(s["albedo"]["bias"]), 0.05)
        # The wind carries the clouds the right way: carried back through the window they agree
        # better with the window's means than left at the valid time (measured +0.012 long wave,
        # +0.029 albedo; carried forward instead, -0.021 and -0.037). The bounds are under half
        # the gains.
        fixed = s["clouds_fixed_at_valid_time"]
        self.assertGreater(s["olr"]["correlation"], fixed["olr"]["correlation"] + 0.006)
        self.assertGreater(s["albedo"]["correlation"], fixed["albedo"]["correlation"] + 0.014)
        # What GFS's own covers explain (measured: 0.89 / 0.94 from the 6-hour means, 0.82 / 0.76
        # from the valid time's): the 6-hour fluxes follow the 6-hour covers better than any
        # instant's, and nephos comes within 0.05 of what the instant's covers explain.
        # Seen from above each cell instead of from GOES-East, on the same cells, both without the
        # limb correction (measured: +5.1 W m-2 more, bias -2.1, r 0.863; the GOES-East bias -2.9
        # W m-2 within 35 deg of nadir, -14.6 at 60-70 deg). The slant view sees more cloud side
        # and a longer path through the air: the window-channel conversion expects nadir
        # radiances. The bounds are half the measured differences; a fault that took the farthest
        # view for each cell reverses them. The limb correction (the air's path, not the clouds'
        # sides) takes back 2.8 W m-2 of the 5.1 (measured); the bound is half that.
        nadir, by_vz = s["olr_nadir_views"], s["olr_as_seen_by_view_zenith"]
        self.assertGreater(nadir["nephos_mean"], s["olr_as_seen"]["nephos_mean"] + 2.5)
        self.assertGreater(s["olr"]["nephos_mean"], s["olr_as_seen"]["nephos_mean"] + 1.3)
        self.assertLess(abs(nadir["bias"]), 5.0)
        self.assertLess(by_vz[-1]["bias"], by_vz[0]["bias"] - 5.5)
        self.assertLess(nadir["farthest_from_view_centre_deg"], 20.0)
        fits = s["gfs_cover_fits"]
        for flux in ("olr", "albedo"):
            self.assertGreater(fits["six_hour_covers"][flux], fits["valid_time_covers"][flux] + 0.05)
            self.assertGreater(s[flux]["correlation"], fits["valid_time_covers"][flux] - 0.05)
        # Where GFS's clouds held through the window (every layer's cover at the valid time within
        # 0.5 of its 6-hour mean: 846 of the 1049 albedo cells), the valid time's clouds stand for
        # the window's, and the albedo's misses fall away: measured r 0.890 there against 0.805 on
        # every cell (0.847 against 0.764 on the validation date). The bound is half the gain; a
        # fault that took the cells whose covers changed instead measures 0.58 and fails it.
        held = s["where_covers_held"][0]
        self.assertEqual(held["largest_layer_cover_change"], 0.5)
        self.assertGreater(held["albedo"]["correlation"], s["albedo"]["correlation"] + 0.04)

    def test_limb_correction_tables_read_as_published(self):
        # The script's reading of Elmer et al.'s (2016) band-14 tables: the clear column's gain to
        # nadir at 60 deg (4.5-5.2 K at the equator, 1.0-1.5 K at 45 deg over the year, the
        # tables evaluated as their code does) and the cloud scaling Q, the share of it left
        # above a cloud's top: rising with the top's pressure, under 0.15 above 500 hPa, 0.3-0.6
        # at 850 hPa (nephos's own columns give 0.43-0.45, atmosphere_test), 1 at the ground.
        # Faults caught: the cloud table's day and latitude scaled by 100 instead of 10^4 (Q = 1
        # at every pressure), the linear and quadratic coefficients swapped (3.4 K at the equator).
        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
        import validate_radiation as v
        for day in (15, 105, 196, 284):
            gain = v.limb_correction_k(np.array([0.0, 45.0]), np.array([60.0, 60.0]), day)
            self.assertTrue(4.5 <= gain[0] <= 5.2 and 1.0 <= gain[1] <= 1.5, (day, gain))
            for lat in (0.0, 30.0, 45.0):
                p = np.array([300.0, 500.0, 700.0, 850.0, 950.0, 1005.0])
                q = v.cloud_scaling(np.full(p.shape, lat), p, day)
                self.assertTrue(np.all(np.diff(q) >= 0) and q[1] < 0.15 and 0.3 < q[3] < 0.6 and q[-1] > 0.999,
                                (day, lat, q))

    def test_valid_time_covers_are_gfs_own_diagnosis(self):
        # The low, middle and high covers diagnosed at the valid time as GFS's radiation does
        # (Xu & Randall 1996, maximum-random overlap, GFS's layer tops) against GFS's own 6-hour
        # means of them. Their global area means differ by -0.005, +0.017 and +0.004 on the
        # embedded date (0.031 summed on the validation date) and correlate 0.77-0.80. The bound
        # on the summed differences, 0.04, sits above what six hours of weather move them; faults
        # seen to cross it: random overlap within a layer (0.065), the low layer's top 100 hPa too
        # high (0.043) or too low (0.091), the middle layer's 100 hPa too high (0.129).
        sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
        import validate_radiation as v
        w = nephos.Weather(str(SAMPLE))
        cover, top_t = v.instantaneous_layer_cover(w)
        area = np.cos(np.radians(w.latitudes))[:, None] * np.ones((1, len(w.longitudes)))
        difference = 0.0
        for layer in ("low", "middle", "high"):
            six_hour = w.field("tcc", f"{layer}CloudLayer")
            difference += abs(np.average(cover[layer], weights=area) - np.average(six_hour, weights=area))
            self.assertGreater(v.weighted_stats(cover[layer], six_hour, area)["correlation"], 0.7, layer)
        self.assertLess(difference, 0.04)
        self.assertLess(np.nanmax(top_t["high"]), np.nanmax(top_t["low"]))


class AbiL1b(unittest.TestCase):
    def test_an_abi_view_is_a_dataset_whose_files_equal_the_clis(self):
        # Scene.render of an ABI sensor: an xarray.Dataset on the fixed grid (x, y scan angles of
        # the PUG's full disc, 2 km coarsened 32-fold: the first pixel centre at -0.151872 + 16 *
        # 56 urad), with the CF grid mapping; nephos.write_abi_l1b writes from it the files
        # `nephos render --format abi-l1b` writes, Rad for Rad. Faults caught: a Dataset whose
        # rows run south first, files written from another grid or time.
        import netCDF4
        import xarray as xr
        ds = nephos.Scene(nephos.Weather(str(SAMPLE)), texture=32).render(sensor="abi:east", abi_step=32,
                                                                          bands=["lwir"])
        self.assertIsInstance(ds, xr.Dataset)
        self.assertEqual(ds["brightness_temperature_lwir"].dims, ("y", "x"))
        self.assertAlmostEqual(float(ds.x[0]), -0.151872 + 16 * 56e-6, places=12)
        self.assertAlmostEqual(float(ds.y[0]), 0.151872 - 16 * 56e-6, places=12)
        self.assertEqual(ds["goes_imager_projection"].attrs["grid_mapping_name"], "geostationary")
        self.assertEqual(ds["brightness_temperature_lwir"].attrs["grid_mapping"], "goes_imager_projection")
        with tempfile.TemporaryDirectory() as d:
            py_files = nephos.write_abi_l1b(ds, str(Path(d) / "py"))
            r = subprocess.run([NEPHOS, "-q", "render", "--sensor", "abi:east", "--abi-step", "32", "--texture", "32",
                                "--bands", "lwir", "--format", "abi-l1b", "--out", str(Path(d) / "cli")],
                               capture_output=True, text=True, timeout=300)
            self.assertEqual(r.returncode, 0, r.stderr)
            cli_files = sorted((Path(d) / "cli").glob("*.nc"))
            self.assertEqual([Path(f).name for f in py_files], [f.name for f in cli_files])
            a, b = netCDF4.Dataset(py_files[0]), netCDF4.Dataset(cli_files[0])
            self.assertTrue((a["Rad"][:] == b["Rad"][:]).all())
            self.assertTrue(np.allclose(a["x"][:], ds.x.values, rtol=0, atol=1e-9))
            # A view transposed (x, y) writes the same files (the square image was written
            # transposed before); what is not an ABI view's Dataset is a ValueError naming it.
            t_files = nephos.write_abi_l1b(ds.transpose("x", "y"), str(Path(d) / "t"))
            self.assertTrue((netCDF4.Dataset(t_files[0])["Rad"][:] == a["Rad"][:]).all())
            # Radiances alone (brightness_temperatures=False, cloud_fields=False, as the CLI's L1b
            # job renders): no brightness temperature or cloud field in the Dataset, the same
            # radiances, and the same files. Fault caught: the brightness temperatures found from
            # another band's table.
            alone = nephos.Scene(nephos.Weather(str(SAMPLE)), texture=32).render(
                sensor="abi:east", abi_step=32, bands=["lwir"], brightness_temperatures=False, cloud_fields=False)
            self.assertEqual(list(alone.data_vars), ["radiance_lwir", "goes_imager_projection"])
            self.assertTrue(np.array_equal(alone["radiance_lwir"].values, ds["radiance_lwir"].values, equal_nan=True))
            r_files = nephos.write_abi_l1b(alone, str(Path(d) / "r"))
            self.assertTrue((netCDF4.Dataset(r_files[0])["Rad"][:] == a["Rad"][:]).all())
            # The Dataset's own float32 arrays are read in place; others are converted first (a
            # float64 copy of the same values writes the same Rad).
            wide = alone.assign(radiance_lwir=alone["radiance_lwir"].astype("float64"))
            w_files = nephos.write_abi_l1b(wide, str(Path(d) / "w"))
            self.assertTrue((netCDF4.Dataset(w_files[0])["Rad"][:] == a["Rad"][:]).all())
            for bad in (5, {"radiance_lwir": 1}, ds.rename({"x": "col"})):
                with self.assertRaisesRegex(ValueError, "'dataset'"):
                    nephos.write_abi_l1b(bad, str(Path(d) / "bad"))
            # A folder that cannot be made is an OSError naming it, as for the command line.
            (Path(d) / "a_file").write_text("")
            with self.assertRaisesRegex(OSError, "a_file/l1b: cannot create output directory"):
                nephos.write_abi_l1b(ds, str(Path(d) / "a_file" / "l1b"))
        self.assertIsInstance(nephos.Scene(nephos.Weather(str(SAMPLE)), texture=8).render(
            sensor="abi:east", abi_step=64, bands=["lwir"], as_dict=True), dict)


    def test_files_written_then_read_print_nothing(self):
        # write_abi_l1b, then netCDF4-python reading the files in the same process (a satpy
        # user's session): nothing on stderr. netCDF-C silences HDF5's error reports for the
        # attributes it probes for, but HDF5 keeps that setting per thread, and netCDF-C sets it
        # once, on the thread that first calls it. Fault caught: the files written from a thread
        # of their own (every later read in the main thread then prints HDF5-DIAG lines).
        code = ("import netCDF4, nephos, sys, tempfile\n"
                "ds = nephos.Scene(nephos.Weather(sys.argv[1]), texture=8).render(sensor='abi:east', abi_step=64,"
                " bands=['mwir', 'lwir'])\n"
                "files = nephos.write_abi_l1b(ds, tempfile.mkdtemp())\n"
                "print(sum(int(netCDF4.Dataset(f)['valid_pixel_count'][...]) > 0 for f in files))\n")
        r = subprocess.run([sys.executable, "-c", code, str(SAMPLE)], capture_output=True, text=True, timeout=300,
                           env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
        self.assertEqual(r.returncode, 0, r.stderr)
        self.assertEqual(r.stdout.strip(), "2")
        self.assertEqual(r.stderr.count("HDF5-DIAG"), 0, r.stderr[:400])

    def test_the_docs_map_example(self):
        # scripts/plot_abi_map.py, docs/render.md's example: satpy opens nephos's files and
        # cartopy draws band 13 on the sensor's projection, the weather's coastline over it.
        # Faults caught: files satpy cannot read or that lack their area, a missing channel
        # that is not said plainly.
        script = Path(__file__).resolve().parent.parent / "scripts" / "plot_abi_map.py"
        ds = nephos.Scene(nephos.Weather(str(SAMPLE)), texture=16).render(sensor="abi:east", abi_step=32,
                                                                          bands=["lwir"])
        with tempfile.TemporaryDirectory() as d:
            nephos.write_abi_l1b(ds, d)
            png = Path(d) / "map.png"
            r = subprocess.run([sys.executable, str(script), d, str(png), "--weather", str(SAMPLE)],
                               capture_output=True, text=True, env=dict(os.environ))
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertTrue(png.read_bytes().startswith(b"\x89PNG"))
            r = subprocess.run([sys.executable, str(script), d, str(png), "--channel", "C07"],
                               capture_output=True, text=True, env=dict(os.environ))
            self.assertNotEqual(r.returncode, 0)
            self.assertIn("no C07 L1b file", r.stderr)


class Lbm(unittest.TestCase):
    def test_the_stages_equal_nephos_lbm_bit_for_bit(self):
        # The pipeline of `nephos lbm` composed in Python: water model, percolation, lighting and
        # ray casting give lbm.nc's fields and render.png's pixels, value for value, and the
        # same step counts.
        model = nephos.WaterModel(grid=(24, 20, 16), seed=5)
        self.assertEqual(model.shape, (16, 20, 24))
        model.step(12)
        self.assertEqual(model.steps_done, 12)
        vapour = model.vapour()
        density, perc_steps = nephos.percolate(vapour, refinement=5, seed=5)
        light, light_steps, residual = nephos.light(density)
        image = nephos.raycast(density, light, size=(64, 48))
        self.assertEqual(image.shape, (48, 64, 3))
        self.assertLess(residual, 1e-5)
        with tempfile.TemporaryDirectory() as d:
            r = subprocess.run([NEPHOS, "-q", "--seed", "5", "lbm", "--grid", "24x20x16", "--iterations", "12", "--size",
                                "64x48", "--out", d], capture_output=True, text=True, timeout=300)
            self.assertEqual(r.returncode, 0, r.stderr)
            self.assertIn(f"percolation K=5: {perc_steps} steps", r.stdout)
            self.assertIn(f"lighting: {light_steps} steps", r.stdout)
            ref = netcdf(Path(d) / "lbm.nc")
            for name, a in (("vapour_density", vapour), ("temperature", model.temperature()),
                            ("percolated_density", density), ("light", light)):
                self.assertTrue(np.array_equal(a, ref[name][:]), name)
            self.assertTrue(np.array_equal(image, read_png_rgb8(Path(d) / "render.png")))
            # A checkpoint saved from Python (the format --resume reads) loads back.
            model.save(str(Path(d) / "ck.bin"))
            resumed = nephos.WaterModel.load(str(Path(d) / "ck.bin"))
            self.assertTrue(np.array_equal(resumed.vapour(), vapour))

    def test_run_lbm_equals_nephos_lbm_bit_for_bit(self):
        # The whole pipeline from keyword arguments: the fields and files of `nephos lbm` with the
        # same options (one request, two front ends).
        with tempfile.TemporaryDirectory() as d:
            py_out, cli_out = Path(d) / "py", Path(d) / "cli"
            got = nephos.run_lbm(grid=(24, 20, 16), iterations=8, percolation=3, size=(48, 36), out=str(py_out), seed=4)
            cli("lbm", "--seed", 4, "--grid", "24x20x16", "--iterations", 8, "--percolation", 3, "--size", "48x36",
                "--out", cli_out)
            ref = netcdf(cli_out / "lbm.nc")
            for name, key in (("vapour_density", "vapour"), ("temperature", "temperature"),
                              ("percolated_density", "percolated_density"), ("light", "light")):
                self.assertTrue(np.array_equal(got[key], ref[name][:]), name)
            self.assertEqual((py_out / "render.png").read_bytes(), (cli_out / "render.png").read_bytes())
            self.assertEqual(got["steps"], 8)
        for kwargs, needle in ((dict(iterations=-1), "'iterations'"), (dict(sun=(0, 95)), "'sun'"),
                               (dict(size=(0, 4)), "'size'"), (dict(percolation=40), "'percolation'")):
            with self.assertRaisesRegex(ValueError, needle, msg=str(kwargs)):
                nephos.run_lbm(grid=(8, 8, 8), out=str(Path(tempfile.gettempdir()) / "never"), **kwargs)

    def test_lbm_errors_name_the_keyword(self):
        with self.assertRaisesRegex(ValueError, "NXxNYxNZ|4..4096"):
            nephos.WaterModel(grid=(2, 20, 16))
        with self.assertRaisesRegex(ValueError, "silos"):
            nephos.WaterModel(grid=(8, 8, 8), silos=-1)
        with self.assertRaisesRegex(ValueError, "fp16"):
            nephos.WaterModel(grid=(8, 8, 8), storage="fp8")
        with self.assertRaisesRegex(ValueError, "sun"):
            nephos.light(np.zeros((8, 8, 8), np.float32), sun=(135, -5))
        with self.assertRaisesRegex(ValueError, "3D"):
            nephos.percolate(np.zeros((8, 8), np.float32))
        for rho10 in (0.0, -1.0, float("nan")):  # each would seed every site dry
            with self.assertRaisesRegex(ValueError, "'rho10': the condensation density"):
                nephos.percolate(np.zeros((6, 6, 6), np.float32), rho10=rho10)
        with self.assertRaisesRegex(ValueError, "shape"):
            nephos.raycast(np.zeros((8, 8, 8), np.float32), np.zeros((8, 8, 4), np.float32))
        with self.assertRaisesRegex(ValueError, "dimension"):
            nephos.light(np.zeros((0, 8, 8), np.float32))
        bad = np.zeros((4, 5, 6), np.float32)
        bad[2, 3, 4] = np.nan
        with self.assertRaisesRegex(ValueError, r"'density': nan at index \(2, 3, 4\)"):
            nephos.light(bad)
        with self.assertRaisesRegex(ValueError, r"'vapour': nan at index \(2, 3, 4\)"):
            nephos.percolate(bad)
        bad[2, 3, 4] = np.inf
        with self.assertRaisesRegex(ValueError, r"'light': inf at index \(2, 3, 4\)"):
            nephos.raycast(np.zeros((4, 5, 6), np.float32), bad)
        with tempfile.TemporaryDirectory() as d:
            (Path(d) / "bad.toml").write_text("[water]\nbuoyancy = 1000.0\n")
            unstable = nephos.WaterModel(grid=(24, 20, 16), config=str(Path(d) / "bad.toml"))
            with self.assertRaisesRegex(RuntimeError, r"step 10: .* at cell \(x=\d+, y=\d+, z=\d+\)"):
                unstable.step(30)


class Particles(unittest.TestCase):
    def test_run_particles_equals_nephos_particles_bit_for_bit(self):
        # One request, two front ends: the frames, the particle sets and the columns of
        # `nephos particles` with the same options, byte for byte, over a region across the date
        # line, with a camera and transparent frames; the frames' particle counts those of
        # frames.csv (its timing columns aside).
        with tempfile.TemporaryDirectory() as d:
            py_out, cli_out = Path(d) / "py", Path(d) / "cli"
            got = nephos.run_particles(region="20,170,60,-140", count=5000, frames=2, size=(160, 90),
                                       camera=(0, -2500, 3, 0, 5), background="transparent", out=str(py_out), seed=3)
            cli("--seed", 3, "particles", "--region", "20,170,60,-140", "--count", 5000, "--frames", 2, "--size",
                "160x90", "--camera", "0,-2500,3,0,5", "--background", "transparent", "--out", cli_out)
            names = sorted(p.name for p in cli_out.iterdir())
            self.assertEqual(names, sorted(p.name for p in py_out.iterdir()))
            self.assertEqual(len([n for n in names if n.endswith(".ply")]), 2)
            for name in names:
                if name != "frames.csv":
                    self.assertEqual((py_out / name).read_bytes(), (cli_out / name).read_bytes(), name)
            rows = (cli_out / "frames.csv").read_text().splitlines()[1:]
            self.assertEqual([(f["time"], f["particles"], f["drawn"]) for f in got["frames"]],
                             [(r.split(",")[1], int(r.split(",")[3]), int(r.split(",")[4])) for r in rows])
            self.assertEqual(got["particles"], 5000)
            self.assertTrue(got["source"].endswith(SAMPLE.name), got["source"])
        for kwargs, needle in ((dict(count=0), "'count'"), (dict(transmission="x"), "'transmission'"),
                               (dict(region="1,2"), "'region'"), (dict(camera=(0, 0, -1, 0, 0)), "'camera'"),
                               (dict(camera=(float("nan"), 0, 1, 0, 0)), "'camera'"),
                               (dict(size=(0, 5)), "'size'"), (dict(refine=-1), "'refine'"),
                               (dict(background="pink"), "'background'"), (dict(wrf="a.nc", weather=["b"]), "'wrf'")):
            with self.assertRaisesRegex(ValueError, needle, msg=str(kwargs)):
                nephos.run_particles(out=str(Path(tempfile.gettempdir()) / "never"), **kwargs)


class Flight(unittest.TestCase):
    def test_frames_equal_nephos_fly_bit_for_bit(self):
        # The same flight, weather change included: every frame the PNG's pixels, and the
        # sprites drawn those of frames.csv; another seed gives other frames.
        with tempfile.TemporaryDirectory() as d:
            cli("--seed", 5, "fly", "--code", "d400", "--frames", 10, "--size", "160x90", "--change", "d100@0.15",
                "--out", d)
            rows = (Path(d) / "frames.csv").read_text().splitlines()[1:]
            flight = nephos.Flight(code="d400", size=(160, 90), seed=5)
            flight.change_weather("d100", 0.15)
            for n in range(10):
                frame = flight.frame()
                self.assertEqual(frame.shape, (90, 160, 3))
                self.assertTrue(np.array_equal(frame, read_png_rgb8(Path(d) / f"frame_{n:04d}.png")), n)
                self.assertEqual(flight.stats["sprites"], int(rows[n].split(",")[2]), n)
                self.assertEqual(flight.stats["impostor_updates"], int(rows[n].split(",")[3]), n)
                # The first frame renders the whole ring; 10 frames fly 43 m, short of a new one.
                self.assertEqual(flight.stats["impostor_sprites"] > 0, n == 0, n)
            self.assertEqual(flight.frames_flown, 10)
            other = nephos.Flight(code="d400", size=(160, 90), seed=6)
            self.assertFalse(np.array_equal(other.frame(), read_png_rgb8(Path(d) / "frame_0000.png")))

    def test_flights_in_threads(self):
        # Two flights drawn at once from two threads, and a flight handed from thread to thread
        # (EGL allows a context current in one thread at a time): the frames of one thread alone.
        import threading
        def frames(flight, n):
            return [flight.frame() for _ in range(n)]
        ref = {s: frames(nephos.Flight(code="d400", size=(64, 36), seed=s), 6) for s in (1, 2)}
        flights = {s: nephos.Flight(code="d400", size=(64, 36), seed=s) for s in (1, 2)}
        got = {}
        threads = [threading.Thread(target=lambda s=s: got.__setitem__(s, frames(flights[s], 3))) for s in (1, 2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        for s in (1, 2):  # then the rest of each flight, each frame from a new thread
            for _ in range(3):
                t = threading.Thread(target=lambda s=s: got[s].append(flights[s].frame()))
                t.start()
                t.join()
            self.assertEqual(len(got[s]), 6)
            for n in range(6):
                self.assertTrue(np.array_equal(got[s][n], ref[s][n]), (s, n))

    def test_sources_background_and_errors(self):
        clear = nephos.Flight(code="d000", size=(64, 36), background="transparent").frame()
        self.assertEqual(clear.shape, (36, 64, 4))
        self.assertEqual(int(clear[..., 3].max()), 0)  # no cloud: transparent everywhere
        self.assertEqual(nephos.Flight(metar="EGLL 051350Z SCT030 BKN045", size=(64, 36)).clouds, 105)
        for kwargs, needle in ((dict(code="d400", metar="FEW030"), "'code'.*one of"), (dict(code="d900"), "d900"),
                               (dict(altitude_ft=1e9), "'altitude_ft'"), (dict(speed_kt=-1), "'speed_kt'"),
                               (dict(size=(0, 10)), "'size'"), (dict(background="blue"), "'background'"),
                               (dict(position=(95, 0)), "'position'"), (dict(gl="vulkan"), "'gl'"),
                               (dict(lod_km=-1), "'lod_km'"), (dict(impostor_radius_km=0), "'impostor_radius_km'")):
            with self.assertRaisesRegex(ValueError, needle, msg=str(kwargs)) as caught:
                nephos.Flight(**kwargs)
            self.assertNotIn("--", str(caught.exception))
        with self.assertRaisesRegex(ValueError, "'at_s'"):
            nephos.Flight(code="d100", size=(16, 9)).change_weather("d400", -1)


if __name__ == "__main__":
    NEPHOS = sys.argv.pop(1)
    unittest.main(verbosity=2)
