#!/usr/bin/python3
"""nephos's top-of-atmosphere radiation against GFS's own, on the GFS grid (docs/VALIDATION.md).

Renders full discs in ABI bands 14 and 1-6 at three instants of the 6-hour window GFS's fluxes
average (5, 3 and 1 h before the valid time), the clouds at each carried back from the valid time
by GFS's wind (Scene.advance), turns each pixel into broadband quantities and averages them onto
the weather's 2.5 deg cells:

  outgoing long-wave flux  F = sigma T_f^4, T_f = T_b (a + b T_b), T_b the 11.2 um brightness
                           temperature, a = 1.228, b = -1.106e-3 K^-1 (Ohring, Gruber & Ellingson
                           1984, J. Clim. Appl. Meteor. 23, 416: NOAA's operational OLR from the
                           AVHRR window channel), T_b first corrected to nadir (Elmer, Berndt &
                           Jedlovec 2016, J. Atmos. Oceanic Technol. 33, 1073, eq. 6 and its cloud
                           scaling, their ABI band-14 coefficients); the mean over the instants
  albedo                   the bands' reflectance factors pi L / (E mu0), weighted by the share of
                           the solar spectrum each stands for (0.30, 0.22, 0.26, 0.06, 0.09, 0.07
                           for bands 1-6: ASTM G173 over 0.3-0.55, 0.55-0.75, 0.75-1.2, 1.2-1.45,
                           1.45-1.9 and 1.9-4 um); the reflected flux summed over the instants over
                           the insolation summed over them

and compares them, area-weighted over the cells the sensor sees within 70 deg of nadir, with
GFS's own 6-hour means: ulwrf at nominalTop over the GOES-East disc (a geostationary sensor at
75.2 W), and uswrf at nominalTop over the insolation of the same 6 hours on the cells lit
throughout them, seen from a geostationary sensor under the Sun at the window's middle (GOES-East
sees little daylight at 00 and 12 UTC). GFS's fluxes come from its radiation code (RRTMG) and
its own clouds: a reference that owes nothing to nephos. It also reports the same with the clouds
left where they are at the valid time (clouds_fixed_at_valid_time), the long-wave bias by the
cells' view zenith (olr_by_view_zenith), the long wave without the limb correction
(olr_as_seen, olr_as_seen_by_view_zenith), with each cell seen from above
(olr_nadir_views: nadir_window_olr), (gfs_cover_fits) how well GFS's own 6-hour and valid-time
layer cloud covers explain the same fluxes in a least-squares fit, and (where_covers_held) both
on the cells whose GFS covers changed little within the window (docs/VALIDATION.md).

Usage: PYTHONPATH=build/python scripts/validate_radiation.py WEATHER OUTDIR [--size N] [--texture N]
Writes OUTDIR/summary.json and OUTDIR/{olr,albedo}.png (nephos left, GFS right).
"""
import argparse
import functools
import json
import math
import struct
import sys
import zlib
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np

import nephos

SOLAR_CONSTANT = 1361.0  # W m-2 at 1 AU (Kopp & Lean 2011)
STEFAN_BOLTZMANN = 5.670374419e-8
OHRING_A, OHRING_B = 1.228, -1.106e-3
SOLAR_BANDS = ["blue", "vis", "nir", "cirrus", "swir16", "swir22"]
SOLAR_WEIGHTS = np.array([0.30, 0.22, 0.26, 0.06, 0.09, 0.07])
GEO_LON, GEO_RADIUS_M, EARTH_RADIUS_M = -75.2, 42164.0e3, 6371008.8
MAX_VZA = 70.0  # deg: cells the sensor sees at most this far from nadir
WINDOW_INSTANTS_H = (5.0, 3.0, 1.0)  # h before the valid time: the middles of the 6-hour window's thirds
COVERS_HELD = (0.5, 0.2)  # where_covers_held: the largest change of a layer's cover within the window
# Nadir views for the long wave (nadir_window_olr): sub-points 25 deg apart, seen from the
# geostationary distance through a field of view that reaches 20 deg of arc around each
NADIR_STEP_DEG, NADIR_ALTITUDE_KM, NADIR_FOV_DEG = 25.0, 35786.0, 8.0
# Elmer et al. (2016) eq. 6 for ABI band 14: powers of day/100 and latitude/100, C1 and C2 [K];
# and its scaling for a cloud's top pressure (rows of 100 coefficients on 59 levels)
TABLES = Path(__file__).resolve().parent.parent / "data" / "validation"
LIMB_TABLE = TABLES / "elmer2016_abi14_limb_correction.csv"
CLOUD_SCALING_TABLE = TABLES / "elmer2016_abi14_cloud_scaling.csv"
LIMB_MAX_LATITUDE_DEG = 72.5  # the tables' fits end there (Elmer's own clip)


def unit(lat, lon):
    la, lo = np.radians(lat), np.radians(lon)
    return np.stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)], axis=-1)


def view_zenith_deg(lat, lon, sat_lon):
    up = unit(lat, lon)
    sat = GEO_RADIUS_M * unit(0.0, sat_lon)
    to_sat = sat - EARTH_RADIUS_M * up
    to_sat /= np.linalg.norm(to_sat, axis=-1, keepdims=True)
    return np.degrees(np.arccos(np.clip(np.sum(up * to_sat, axis=-1), -1, 1)))


def cos_sun_zenith(lat, lon, time):
    s = nephos.sun(time.strftime("%Y-%m-%dT%H:%M:%SZ"))
    return np.sum(unit(lat, lon) * unit(s["subsolar_latitude_deg"], s["subsolar_longitude_deg"]), axis=-1), s


def reflectance(image, sun, mu0):
    """The solar-weighted mean of the bands' reflectance factors pi L / (E mu0)."""
    bands = {b["name"]: b for b in nephos.bands()}
    refl = np.zeros_like(mu0)
    for weight, name in zip(SOLAR_WEIGHTS, SOLAR_BANDS):
        e = bands[name]["solar_irradiance_w_m2_um"] / sun["distance_au"] ** 2
        refl += weight * np.pi * image["radiance_" + name] / (e * np.maximum(mu0, 1e-6))
    return np.where(mu0 > 0.1, refl / SOLAR_WEIGHTS.sum(), np.nan)


def nearest_cell(lat, lon, lats, lons):
    """The weather grid's row and column nearest each point (rows unclamped)."""
    j = np.rint((lat - lats[0]) / (lats[1] - lats[0])).astype(int)
    i = np.rint(((lon - lons[0]) % 360) / (lons[1] - lons[0])).astype(int) % len(lons)
    return j, i


def grid_mean(values, lat, lon, lats, lons):
    """The mean of the finite pixel values in each weather cell (nearest node), and their count."""
    ok = np.isfinite(values) & np.isfinite(lat) & np.isfinite(lon)
    j, i = nearest_cell(np.where(ok, lat, lats[0]), np.where(ok, lon, lons[0]), lats, lons)
    ok &= (j >= 0) & (j < len(lats))
    total = np.zeros((len(lats), len(lons)))
    count = np.zeros_like(total)
    np.add.at(total, (j[ok], i[ok]), values[ok])
    np.add.at(count, (j[ok], i[ok]), 1)
    with np.errstate(invalid="ignore"):
        return total / count, count


def instantaneous_layer_cover(w):
    """GFS's low, middle and high cloud cover at the valid time, diagnosed as GFS's radiation does
    from the instantaneous profiles: Xu & Randall (1996) per level (nephos.cloud_fraction, the
    masks' own diagnosis; no cloud where the file has no condensate); maximum-random overlap
    within each layer; the layers' tops at 650 and 400 hPa equatorward of 45 deg, rising linearly
    to 750 and 500 hPa at the poles (GFS's cloud domains). Returns ({layer: cover}, {layer:
    temperature at its highest cloudy level [K]})."""
    p = w.pressure_levels_pa
    t, qc = w.level_field("t"), w.level_field("clwmr")
    cf = nephos.cloud_fraction(w.level_field("r"), np.nan_to_num(qc, nan=0.0), t, p[:, None, None])
    lat = np.abs(w.latitudes)[:, None] * np.ones((1, len(w.longitudes)))
    rise = np.clip(4 * np.radians(lat) / np.pi - 1, 0, 1)
    tops = {"low": 65000 + 10000 * rise, "middle": 40000 + 10000 * rise, "high": np.zeros_like(rise)}
    bottoms = {"low": np.full_like(rise, np.inf), "middle": tops["low"], "high": tops["middle"]}
    cover, top_t = {}, {}
    for layer in ("low", "middle", "high"):
        clear, run = np.ones_like(rise), np.zeros_like(rise)
        top = np.full_like(rise, np.nan)
        for k in range(len(p)):  # bottom up: contiguous cloudy levels overlap maximally
            c = np.where((p[k] < bottoms[layer]) & (p[k] >= tops[layer]), cf[k], 0.0)
            clear = np.where((c <= 0) & (run > 0), clear * (1 - run), clear)
            run = np.where(c > 0, np.maximum(run, c), 0.0)
            top = np.where(c > 0.01, t[k], top)
        cover[layer], top_t[layer] = 1 - clear * (1 - run), top
    return cover, top_t


def cover_change(w):
    """The largest change of a GFS layer's cloud cover within the 6-hour window on each cell: the
    largest |6-hour mean - valid time's| of the low, middle and high covers (instantaneous_layer_cover)."""
    now, _ = instantaneous_layer_cover(w)
    return np.maximum.reduce([np.abs(w.field("tcc", f"{layer}CloudLayer") - now[layer]) for layer in now])


def where_covers_held(w, olr, gfs_olr, albedo, gfs_albedo, area):
    """nephos's fluxes on the cells whose GFS layer covers changed by less than COVERS_HELD within
    the window (cover_change), where the valid time's clouds stand for the 6-hour mean's, beside
    what GFS's own covers explain on the same cells (reference_fits)."""
    change = cover_change(w)
    rows = []
    for held in COVERS_HELD:
        o, a = np.where(change < held, olr, np.nan), np.where(change < held, albedo, np.nan)
        rows.append({"largest_layer_cover_change": held, "olr": weighted_stats(o, gfs_olr, area),
                     "albedo": weighted_stats(a, gfs_albedo, area),
                     "gfs_cover_fits": reference_fits(w, gfs_olr, gfs_albedo, np.isfinite(o) & np.isfinite(gfs_olr),
                                                      np.isfinite(a) & np.isfinite(gfs_albedo), area)})
    return rows


def fit_correlation(target, predictors, cells, area):
    """The area-weighted correlation with `target` of its least-squares fit from `predictors` on `cells`
    (fitted on the same cells: an optimistic measure of what they explain)."""
    x = np.stack([np.ones_like(target)] + [np.nan_to_num(v) for v in predictors], axis=-1)[cells]
    s = np.sqrt(area[cells])
    coef, *_ = np.linalg.lstsq(x * s[:, None], target[cells] * s, rcond=None)
    fit = np.full_like(target, np.nan)
    fit[cells] = x @ coef
    return weighted_stats(fit, target, area)["correlation"]


def reference_fits(w, gfs_olr, gfs_albedo, olr_cells, albedo_cells, area):
    """What GFS's own cloud cover explains of its fluxes: linear fits from the 6-hour mean layer covers
    (the fields the fluxes were averaged with) and from the covers at the valid time (all that an
    instantaneous rendering can know), with the same surface and column predictors (the layers'
    cloud-top temperatures are the valid time's in both)."""
    sigma_ts4 = STEFAN_BOLTZMANN * w.field("t", "surface") ** 4
    pwat, al = w.field("pwat", "atmosphereSingleLayer"), w.field("al", "surface")
    now, now_t = instantaneous_layer_cover(w)
    mean = {layer: w.field("tcc", f"{layer}CloudLayer") for layer in ("low", "middle", "high")}
    out = {}
    for name, cover in (("six_hour_covers", mean), ("valid_time_covers", now)):
        c = [cover[layer] for layer in ("low", "middle", "high")]
        emission = [cover[layer] * STEFAN_BOLTZMANN * np.nan_to_num(now_t[layer], nan=0.0) ** 4
                    for layer in ("low", "middle", "high")]
        out[name] = {
            "olr": fit_correlation(gfs_olr, c + emission + [sigma_ts4, pwat], olr_cells, area),
            "albedo": fit_correlation(gfs_albedo, c + [al, al * (1 - np.maximum.reduce(c))], albedo_cells, area),
        }
    return out


def weighted_stats(a, b, w):
    ok = np.isfinite(a) & np.isfinite(b) & (w > 0)
    a, b, w = a[ok], b[ok], w[ok]
    ma, mb = np.average(a, weights=w), np.average(b, weights=w)
    cov = np.average((a - ma) * (b - mb), weights=w)
    r = cov / math.sqrt(np.average((a - ma) ** 2, weights=w) * np.average((b - mb) ** 2, weights=w))
    return {"cells": int(ok.sum()), "correlation": float(r), "bias": float(ma - mb), "nephos_mean": float(ma),
            "gfs_mean": float(mb)}


def write_png(path, rgb):
    """An 8-bit RGB PNG (zlib and the PNG chunk format, no image library)."""
    h, w, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[y].astype(np.uint8).tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    Path(path).write_bytes(png)


def colour(field, lo, hi):
    """Dark blue - white - dark red, grey where NaN; north up."""
    x = np.clip((field - lo) / (hi - lo), 0, 1)
    r = np.where(x < 0.5, 2 * x, 1.0)
    g = np.where(x < 0.5, 2 * x, 2 - 2 * x)
    b = np.where(x < 0.5, 1.0, 2 - 2 * x)
    rgb = np.stack([r, g, b], axis=-1) * 235 + 10
    rgb[~np.isfinite(field)] = 128
    return rgb[::-1]


def side_by_side(path, a, b, lo, hi, rows, cols, scale=4):
    pa, pb = colour(a[rows][:, cols], lo, hi), colour(b[rows][:, cols], lo, hi)
    gap = np.full((pa.shape[0], 2, 3), 255.0)
    img = np.concatenate([pa, gap, pb], axis=1)
    write_png(path, np.repeat(np.repeat(img, scale, axis=0), scale, axis=1))


@functools.cache
def data_table(path, header_lines):
    """A data table's numbers (its '#' citation lines and column header skipped), read once."""
    return np.loadtxt(path, delimiter=",", comments="#", skiprows=header_lines)


def limb_correction_k(lat, vza_deg, day_of_year):
    """What a clear column's 11.2 um brightness temperature gains from view zenith vza_deg to nadir
    [K]: Elmer, Berndt & Jedlovec (2016) eq. 6, C1 x + C2 x^2 with x = |ln cos vza|, C1 and C2
    their polynomials in day of year and latitude for ABI band 14 (LIMB_TABLE)."""
    table = data_table(LIMB_TABLE, 6)
    d = day_of_year / 100.0
    lt = np.clip(np.nan_to_num(lat), -LIMB_MAX_LATITUDE_DEG, LIMB_MAX_LATITUDE_DEG) / 100.0
    c1, c2 = np.zeros_like(lt), np.zeros_like(lt)
    for i, j, k1, k2 in table:
        term = d**i * lt**j
        c1, c2 = c1 + k1 * term, c2 + k2 * term
    x = np.abs(np.log(np.cos(np.radians(np.clip(np.nan_to_num(vza_deg), 0.0, 89.0)))))
    return c1 * x + c2 * x * x


def cloud_scaling(lat, cloud_top_hpa, day_of_year):
    """Elmer et al.'s (2016) share Q of the clear column's limb correction that applies to a cloud
    whose top lies at cloud_top_hpa: their ABI band-14 polynomials in day of year and latitude
    (both / 10^4, the result / 100, at most 1) on 59 pressure levels, each holding between the
    midpoints to its neighbours (CLOUD_SCALING_TABLE)."""
    table = data_table(CLOUD_SCALING_TABLE, 8)
    levels, coef = table[:, 0], table[:, 1:]
    d = day_of_year / 1e4
    lt = np.clip(np.nan_to_num(lat), -LIMB_MAX_LATITUDE_DEG, LIMB_MAX_LATITUDE_DEG) / 1e4
    row = np.searchsorted(np.append(0.5 * (levels[1:] + levels[:-1]), 1013.0), np.nan_to_num(cloud_top_hpa, nan=1013.0))
    row = np.clip(row, 0, len(levels) - 1)
    q = np.zeros_like(lt)
    for k in range(coef.shape[1]):
        q += coef[row, k] * d ** (k // 10) * lt ** (k % 10)
    return np.minimum(q / 100, 1.0)


def cloud_top_pressure_hpa(w, lat, lon, altitude_m):
    """The pressure [hPa] at altitude_m above each pixel: GFS's geopotential heights of its nearest
    cell, ln p linear between levels (clamped to the file's levels)."""
    gh, lnp = w.level_field("gh"), np.log(np.asarray(w.pressure_levels_pa) / 100.0)
    j, i = nearest_cell(np.nan_to_num(lat), np.nan_to_num(lon), w.latitudes, w.longitudes)
    z = gh[:, np.clip(j, 0, len(w.latitudes) - 1), i]  # (levels, pixels...), rising with the level index
    k = np.clip((z < np.nan_to_num(altitude_m)[None]).sum(axis=0) - 1, 0, len(lnp) - 2)
    z0, z1 = np.take_along_axis(z, k[None], 0)[0], np.take_along_axis(z, k[None] + 1, 0)[0]
    f = np.clip((np.nan_to_num(altitude_m) - z0) / np.maximum(z1 - z0, 1.0), 0.0, 1.0)
    return np.exp(lnp[k] + f * (lnp[k + 1] - lnp[k]))


def ohring_olr(img, limb=None):
    """The outgoing long-wave flux [W m-2] of each pixel from its 11.2 um brightness temperature
    (Ohring, Gruber & Ellingson 1984). limb: (view zenith [deg], day of year, weather) to correct
    the temperature to nadir first, as Elmer et al. (2016) do: the clear column's correction
    (limb_correction_k) for the radiance that comes up through it, 1 - f e, and that times their
    cloud scaling Q at the cloud's top pressure (cloud_scaling) for the cloud's own, f e; f the
    pixel's cloud fraction, e = 1 - exp(-tau / 2) its clouds' emissivity, tau / 2 their absorption
    optical depth at 11 um (half the visible extinction: particles much larger than the
    wavelength, extinction efficiency 2, absorption 1)."""
    tb = img["brightness_temperature_lwir11"]
    if limb is not None:
        vza, day, w = limb
        lat, top = img["latitude"], img["cloud_top_altitude"]
        q = cloud_scaling(lat, cloud_top_pressure_hpa(w, lat, img["longitude"], top), day)
        cloud = np.nan_to_num(img["cloud_fraction"]) * -np.expm1(-0.5 * np.nan_to_num(img["cloud_optical_depth"]))
        tb = tb + (1 - cloud * (1 - np.where(np.isfinite(top), q, 1.0))) * limb_correction_k(lat, vza, day)
    return STEFAN_BOLTZMANN * (tb * (OHRING_A + OHRING_B * tb)) ** 4


def great_circle_deg(lat1, lon1, lat2, lon2):
    return np.degrees(np.arccos(np.clip(np.sum(unit(lat1, lon1) * unit(lat2, lon2), axis=-1), -1, 1)))


def nadir_views():
    """Sub-points of the nadir views that see every cell of the GOES-East disc near its zenith:
    rows NADIR_STEP_DEG apart in latitude, NADIR_STEP_DEG of arc apart along each row."""
    views = []
    for lat0 in np.arange(-75.0, 75.1, NADIR_STEP_DEG):
        dlon = NADIR_STEP_DEG / math.cos(math.radians(lat0))
        for k in range(-int(180 / dlon), int(180 / dlon) + 1):
            lon0 = (GEO_LON + k * dlon + 180) % 360 - 180
            if great_circle_deg(lat0, lon0, 0.0, GEO_LON) < MAX_VZA + NADIR_STEP_DEG:
                views.append((float(lat0), float(lon0)))
    return views


def nadir_window_olr(scene, w, valid, pixels, at_h):
    """The long-wave estimate of window_means(carried=True) with each cell seen from above: at
    each instant, the cells from the nadir view (NADIR_ALTITUDE_KM, NADIR_FOV_DEG) whose
    sub-point is nearest (their view zenith below ~20 deg), as the window-channel conversion
    expects (NOAA's operational OLR corrects its window radiances to nadir before it; Gruber &
    Krueger 1984, Bull. Amer. Meteor. Soc. 65, 958). at_h: where the scene stands [h from the
    valid time]. Returns the cells' flux and the largest distance of a cell from its view's
    sub-point [deg]."""
    lats, lons = w.latitudes, w.longitudes
    la, lo = np.meshgrid(lats, lons, indexing="ij")
    views = nadir_views()
    olr_sum, n_min, farthest = 0.0, np.inf, 0.0
    for hours in WINDOW_INSTANTS_H:
        scene.advance(-hours - at_h)
        at_h = -hours
        stamp = (valid - timedelta(hours=hours)).strftime("%Y-%m-%dT%H:%M:%SZ")
        nearest, flux, count = np.full(la.shape, np.inf), np.full(la.shape, np.nan), np.zeros(la.shape)
        for lat0, lon0 in views:
            img = scene.render(sensor=f"leo:{lat0},{lon0},{NADIR_ALTITUDE_KM},{NADIR_FOV_DEG}", size=(pixels, pixels),
                               bands=["lwir11"], time=stamp)
            g, n = grid_mean(ohring_olr(img), img["latitude"], img["longitude"], lats, lons)
            d = great_circle_deg(la, lo, lat0, lon0)
            take = (n >= 20) & (d < nearest)
            flux[take], nearest[take], count[take] = g[take], d[take], n[take]
        olr_sum, n_min = olr_sum + flux, np.minimum(n_min, count)
        seen = view_zenith_deg(la, lo, GEO_LON) < MAX_VZA
        farthest = max(farthest, float(np.nanmax(np.where(seen, nearest, np.nan))))
    olr = olr_sum / len(WINDOW_INSTANTS_H)
    olr[(n_min < 20) | (view_zenith_deg(la, lo, GEO_LON) >= MAX_VZA)] = np.nan
    return olr, farthest


def by_view_zenith(olr, gfs, la, lo, area):
    """Bias and correlation of the GOES-East estimate in bands of the cells' view zenith [deg]."""
    vz = view_zenith_deg(la, lo, GEO_LON)
    rows = []
    for lo_deg, hi_deg in ((0, 35), (35, 50), (50, 60), (60, 70)):
        inside = (vz >= lo_deg) & (vz < hi_deg)
        st = weighted_stats(np.where(inside, olr, np.nan), gfs, area)
        rows.append({"view_zenith_deg": [lo_deg, hi_deg], "cells": st["cells"], "bias": st["bias"],
                     "correlation": st["correlation"]})
    return rows


def window_means(scene, w, valid, size, sw_lon, carried):
    """nephos's outgoing long-wave flux and albedo on the weather's cells, as GFS's 6-hour means are
    defined: rendered at WINDOW_INSTANTS_H before the valid time; long wave over the GOES-East
    disc, the mean of the instants' fluxes; short wave under the Sun at the window's middle
    (sw_lon), the reflected flux summed over the instants over the insolation summed over them.
    carried: the clouds at each instant carried back from the valid time by GFS's wind
    (Scene.advance, which leaves the scene there); else as they are at the valid time. Cells with
    fewer than 20 pixels are NaN. Returns the long wave corrected to nadir, the albedo and the long
    wave as seen (no limb correction)."""
    lats, lons = w.latitudes, w.longitudes
    olr_sum, seen_sum, reflected, incident = 0.0, 0.0, 0.0, 0.0
    n_olr = n_alb = np.inf
    at_h = 0.0  # the scene's advance from the valid time [h]
    for hours in WINDOW_INSTANTS_H:
        if carried:
            scene.advance(-hours - at_h)
            at_h = -hours
        when = valid - timedelta(hours=hours)
        stamp = when.strftime("%Y-%m-%dT%H:%M:%SZ")
        if carried or hours == WINDOW_INSTANTS_H[0]:  # the long wave does not see the Sun move
            img = scene.render(sensor=f"geo:{GEO_LON}", size=size, bands=["lwir11"], time=stamp)
            vza = view_zenith_deg(img["latitude"], img["longitude"], GEO_LON)
            limb = (vza, when.timetuple().tm_yday, w)
            g, n = grid_mean(np.where(vza < MAX_VZA, ohring_olr(img, limb), np.nan), img["latitude"],
                             img["longitude"], lats, lons)
            g_seen, _ = grid_mean(np.where(vza < MAX_VZA, ohring_olr(img), np.nan), img["latitude"],
                                  img["longitude"], lats, lons)
        olr_sum, seen_sum, n_olr = olr_sum + g, seen_sum + g_seen, np.minimum(n_olr, n)
        sw = scene.render(sensor=f"geo:{sw_lon}", size=size, bands=SOLAR_BANDS, time=stamp)
        lat, lon = sw["latitude"], sw["longitude"]
        mu0, sun = cos_sun_zenith(lat, lon, when)
        irradiance = np.maximum(mu0, 0) / sun["distance_au"] ** 2  # in units of the solar constant
        refl = reflectance(sw, sun, mu0)
        seen = (view_zenith_deg(lat, lon, sw_lon) < MAX_VZA) & np.isfinite(refl)
        f, n_f = grid_mean(np.where(seen, refl * irradiance, np.nan), lat, lon, lats, lons)
        e, _ = grid_mean(np.where(seen, irradiance, np.nan), lat, lon, lats, lons)
        reflected, incident, n_alb = reflected + f, incident + e, np.minimum(n_alb, n_f)
    with np.errstate(invalid="ignore", divide="ignore"):
        alb = reflected / incident
    olr, olr_seen = olr_sum / len(WINDOW_INSTANTS_H), seen_sum / len(WINDOW_INSTANTS_H)
    olr[n_olr < 20] = olr_seen[n_olr < 20] = np.nan
    alb[n_alb < 20] = np.nan
    return olr, alb, olr_seen


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("weather")
    ap.add_argument("out")
    ap.add_argument("--size", type=int, default=600)
    ap.add_argument("--texture", type=int, default=128)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    w = nephos.Weather(args.weather)
    valid = datetime.strptime(w.valid_time, "%Y-%m-%dT%H:%M:%SZ").replace(tzinfo=timezone.utc)
    scene = nephos.Scene(w, texture=args.texture, seed=1)
    size = (args.size, args.size)
    _, mid_sun = cos_sun_zenith(0.0, 0.0, valid - timedelta(hours=3))
    sw_lon = round(mid_sun["subsolar_longitude_deg"], 1)
    lats, lons = w.latitudes, w.longitudes
    # The clouds as they are at the valid time, then carried back through the window by the wind.
    fixed_olr, fixed_alb, _ = window_means(scene, w, valid, size, sw_lon, carried=False)
    olr_grid, alb_grid, seen_grid = window_means(scene, w, valid, size, sw_lon, carried=True)
    # The same clouds seen from above each cell (the carried run left the scene at the last instant).
    nadir_olr, farthest = nadir_window_olr(scene, w, valid, max(120, args.size // 3), -WINDOW_INSTANTS_H[-1])
    la, lo = np.meshgrid(lats, lons, indexing="ij")
    area = np.cos(np.radians(la))
    # GFS: outgoing long-wave; short wave over the insolation of its 6-hour window, on cells lit
    # throughout it (the Sun above 5 deg at every one of 37 instants).
    gfs_olr = w.field("ulwrf", "nominalTop")
    insolation = np.zeros_like(la)
    lit = np.ones_like(la, dtype=bool)
    for k in range(37):
        m, s = cos_sun_zenith(la, lo, valid - timedelta(hours=6) + timedelta(minutes=10 * k))
        insolation += SOLAR_CONSTANT / s["distance_au"] ** 2 * np.maximum(m, 0) / 37
        lit &= m > math.sin(math.radians(5))
    gfs_albedo = np.where(lit, w.field("uswrf", "nominalTop") / np.maximum(insolation, 1e-6), np.nan)
    summary = {
        "weather": w.source, "valid_time": w.valid_time, "size": args.size, "texture": args.texture,
        "longwave_sensor": f"geo:{GEO_LON}", "shortwave_sensor": f"geo:{sw_lon}",
        "olr": weighted_stats(olr_grid, gfs_olr, area),
        "albedo": weighted_stats(alb_grid, gfs_albedo, area),
        "olr_by_view_zenith": by_view_zenith(olr_grid, gfs_olr, la, lo, area),
        "olr_as_seen": weighted_stats(seen_grid, gfs_olr, area),
        "olr_as_seen_by_view_zenith": by_view_zenith(seen_grid, gfs_olr, la, lo, area),
        "olr_nadir_views": dict(weighted_stats(np.where(np.isfinite(olr_grid), nadir_olr, np.nan), gfs_olr, area),
                                farthest_from_view_centre_deg=farthest),
        "clouds_fixed_at_valid_time": {"olr": weighted_stats(fixed_olr, gfs_olr, area),
                                       "albedo": weighted_stats(fixed_alb, gfs_albedo, area)},
        "gfs_cover_fits": reference_fits(w, gfs_olr, gfs_albedo, np.isfinite(olr_grid) & np.isfinite(gfs_olr),
                                         np.isfinite(alb_grid) & np.isfinite(gfs_albedo), area),
        "where_covers_held": where_covers_held(w, olr_grid, gfs_olr, alb_grid, gfs_albedo, area),
    }
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    rows = np.where((lats >= -70) & (lats <= 70))[0]

    def columns(centre):
        order = np.argsort((lons - centre + 180) % 360)
        return order[np.abs((lons[order] - centre + 180) % 360 - 180) <= 75]

    side_by_side(out / "olr.png", olr_grid, np.where(np.isfinite(olr_grid), gfs_olr, np.nan), 100, 320, rows,
                 columns(GEO_LON))
    side_by_side(out / "albedo.png", alb_grid, np.where(np.isfinite(alb_grid), gfs_albedo, np.nan), 0, 0.8, rows,
                 columns(sw_lon))
    print(json.dumps(summary, indent=2))


if __name__ == "__main__":
    sys.exit(main())
