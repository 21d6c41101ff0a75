#!/usr/bin/python3
"""Opens nephos's ABI L1b files in satpy and plots a band on a map (docs/render.md).

The map is the sensor's own geostationary projection (cartopy, from the pyresample area satpy
reads from the files), with a 10-degree graticule and the coastline drawn as the weather's
land-sea mask at one half (cartopy's own coastlines would need a download).

Usage: scripts/plot_abi_map.py L1B_DIR OUT.png [--channel C13] [--weather GRIB]
"""
import argparse
import glob
import sys

import cartopy.crs as ccrs
import matplotlib
import numpy as np
from satpy import Scene

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402 (after the back end is chosen)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("l1b_dir")
    ap.add_argument("out")
    ap.add_argument("--channel", default="C13")
    ap.add_argument("--weather", help="GRIB file whose land-sea mask draws the coastline")
    args = ap.parse_args()
    files = glob.glob(f"{args.l1b_dir}/OR_ABI-L1b-Rad*-M6{args.channel}_*.nc")
    if not files:
        sys.exit(f"plot_abi_map: no {args.channel} L1b file in {args.l1b_dir}")
    scn = Scene(reader="abi_l1b", filenames=files)
    scn.load([args.channel])
    data = scn[args.channel]
    crs = data.attrs["area"].to_cartopy_crs()
    ax = plt.figure(figsize=(6, 6)).add_subplot(projection=crs)
    thermal = data.attrs["units"] == "K"
    image = ax.imshow(data.values, transform=crs, extent=crs.bounds, origin="upper",
                      cmap="Greys" if thermal else "gray", vmin=190 if thermal else 0, vmax=310 if thermal else 100)
    if args.weather:
        import nephos
        w = nephos.Weather(args.weather)
        lon = (w.longitudes + 180) % 360 - 180  # the seam at 180 deg, off the GOES discs
        order = np.argsort(lon)
        lat2, lon2 = np.meshgrid(np.radians(w.latitudes), np.radians(lon[order]), indexing="ij")
        sub_lon = np.radians(data.attrs["orbital_parameters"]["satellite_nominal_longitude"])
        seen = np.cos(lat2) * np.cos(lon2 - sub_lon) > np.cos(np.radians(78))  # within 78 deg of the subpoint
        land = np.where(seen, w.field("lsm")[:, order], np.nan)
        ax.contour(lon[order], w.latitudes, land, levels=[0.5], colors="goldenrod", linewidths=0.6,
                   transform=ccrs.PlateCarree())
    ax.gridlines(xlocs=range(-180, 181, 10), ylocs=range(-80, 81, 10), linewidth=0.3, color="steelblue")
    plt.colorbar(image, ax=ax, shrink=0.7, label=f"{args.channel} {data.attrs['standard_name']} [{data.attrs['units']}]")
    ax.set_title(f"{data.attrs['platform_name']} ABI {args.channel}, {data.attrs['start_time']:%Y-%m-%d %H:%M} UTC")
    plt.savefig(args.out, dpi=100, bbox_inches="tight")


if __name__ == "__main__":
    main()
