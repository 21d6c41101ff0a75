#pragma once
// Simulated ABI Level 1b radiance files: one NetCDF-4 file per band, named and laid out as GOES-R
// PUG Vol. 3 (L1b) specifies and satpy's `abi_l1b` reader reads: Rad packed as scaled 16-bit
// integers, DQF, the fixed grid's x/y and goes_imager_projection, the band's identity, its Planck
// coefficients (thermal bands) or solar irradiance (reflective bands), the Earth-Sun distance,
// the satellite's nominal position and the time coverage.
#include <filesystem>
#include <string>
#include <vector>

#include "nephos/core/time.hpp"
#include "nephos/optics/optics.hpp"
#include "nephos/render/renderer.hpp"
#include "nephos/render/sensor.hpp"

namespace nephos::render {

/// The Planck coefficients of an ABI L1b file's thermal band (PUG Vol. 3, section 4.2.8.1): BT =
/// (fk2 / ln(fk1 / L + 1) - bc1) / bc2 for radiance L [mW m^-2 sr^-1 (cm^-1)^-1].
struct PlanckCoefficients {
  double fk1 = 0, fk2 = 0, bc1 = 0, bc2 = 1;
  double radiance(double bt_k) const;  ///< the inverse: L at brightness temperature bt_k
  double brightness_temperature(double radiance) const;
};
/// The coefficients of nephos's band b (a flat response between its edges): fk1 = c1 nu^3, fk2 =
/// c2 nu at its centre wavenumber nu, bc1 and bc2 the least-squares line of the centre's
/// brightness temperature against the band-mean one over 180-340 K.
PlanckCoefficients planck_coefficients(const optics::Band& b);
/// The central wavenumber [cm^-1] of `platform`'s ("G16", "G18") ABI band `abi_band` (7-16) from
/// its measured spectral response (CRTM's), or 0 where not known.
double abi_central_wavenumber_cm1(const std::string& platform, int abi_band);
/// Where abi_planck_coefficients() takes a band's coefficients from.
enum class PlanckSource {
  published,           ///< as NOAA's L1b files print them (GOES-16 bands 7-16, GOES-18 band 13)
  central_wavenumber,  ///< fk1, fk2 at the measured central wavenumber; bc1, bc2 GOES-16's (GOES-18)
  nephos_band,         ///< planck_coefficients(b): nephos's own band
};
PlanckSource planck_source(const std::string& platform, const optics::Band& b);
/// The coefficients `platform`'s ("G16", "G18") L1b files carry for thermal band b, from the
/// source planck_source() names. Rad is written as the radiance these give nephos's brightness
/// temperature, so satpy's BT is nephos's whichever.
PlanckCoefficients abi_planck_coefficients(const std::string& platform, const optics::Band& b);

/// The file name ABI gives band `abi_band`'s L1b file of `view` for a scan from `start`:
/// OR_ABI-L1b-Rad{F,C,M}-M6C{nn}_{G16,G18}_s{YYYYJJJHHMMSSt}_e{...}_c{...}.nc (end and creation:
/// start plus the mode-6 scan time of the sector, 600 s full disc, 300 s CONUS, 60 s meso).
std::string abi_l1b_file_name(const FixedGridView& view, int abi_band, const UtcTime& start);

/// The bands write_abi_l1b() writes, not owned: per band its name, its radiances [W m^-2 sr^-1
/// um^-1] and, for a thermal band, its brightness temperatures [K] or nullptr (then found from the
/// radiances by brightness_temperatures()), each width x height, row-major from the north-west.
struct L1bBands {
  int width = 0, height = 0;
  std::vector<std::string> bands;
  std::vector<const float*> radiance, brightness_temperature;
};
/// The bands of a rendered image, pointing into it.
L1bBands l1b_bands(const RenderImage& image);

/// Writes each band of `image` (rendered by Sensor::abi(view) at time `start`, the Sun at
/// `sun_distance_au`) as an L1b file into `dir` (created if need be); returns their paths.
/// Pixels off the ellipsoid are _FillValue. Thermal bands' Rad is the radiance their
/// coefficients give nephos's brightness temperature (so that BT round-trips); reflective bands'
/// Rad is nephos's radiance.
std::vector<std::filesystem::path> write_abi_l1b(const std::filesystem::path& dir, const L1bBands& image,
                                                 const FixedGridView& view, const UtcTime& start,
                                                 double sun_distance_au);
/// The same, of a rendered image's bands.
std::vector<std::filesystem::path> write_abi_l1b(const std::filesystem::path& dir, const RenderImage& image,
                                                 const FixedGridView& view, const UtcTime& start,
                                                 double sun_distance_au);

}  // namespace nephos::render
