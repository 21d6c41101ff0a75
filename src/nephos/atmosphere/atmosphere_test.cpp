#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "nephos/atmosphere/band_model.hpp"
#include "nephos/atmosphere/clear_sky.hpp"
#include "nephos/atmosphere/profile.hpp"
#include "nephos/atmosphere/rayleigh.hpp"

namespace nephos::atmosphere {
namespace {

TEST(Profile, UsStandardColumnsOfWaterAndOzone) {
  const Profile& s = us_standard();
  std::printf("US standard: PW %.3f kg m-2, O3 %.1f DU\n", s.precipitable_water_kg_m2(), s.total_ozone_du());
}

TEST(BandModel, FitsPerBand) {
  for (const optics::Band& b : optics::bands()) {
    const BandGasModel& m = gas_model(b);
    int terms = 0;
    for (const auto& s : m.sub)
      for (const auto& g : s.gas) terms += g.n;
    std::printf("%-7s %zu sub-bands, %d terms, fit error %.4f\n", b.name.c_str(), m.sub.size(), terms, m.fit_error);
  }
}

// The US standard atmosphere on levels every dz metres up to 60 km (log-pressure, linear
// temperature and mixing ratios between its 1 km levels), its water vapour scaled by h2o_scale.
Profile fine_us_standard(double dz, double h2o_scale = 1, double t_surface_offset = 0) {
  const Profile& s = us_standard();
  Profile f;
  for (double z = 0; z <= 60e3; z += dz) {
    std::size_t hi = 1;
    while (s.z_m[hi] < z) ++hi;
    const double u = (z - s.z_m[hi - 1]) / (s.z_m[hi] - s.z_m[hi - 1]);
    auto lin = [&](const std::vector<double>& v) { return v[hi - 1] + u * (v[hi] - v[hi - 1]); };
    f.z_m.push_back(z);
    f.p_pa.push_back(std::exp(std::log(s.p_pa[hi - 1]) + u * (std::log(s.p_pa[hi]) - std::log(s.p_pa[hi - 1]))));
    f.t_k.push_back(lin(s.t_k) + t_surface_offset * std::max(0.0, 1 - z / 10e3));
    f.h2o_vmr.push_back(lin(s.h2o_vmr) * (z < 12e3 ? h2o_scale : 1.0));
    f.o3_vmr.push_back(lin(s.o3_vmr));
  }
  f.skin_temperature_k = f.t_k.front();
  return f;
}

TEST(ClearSky, UsStandardNadir) {
  const Profile s = fine_us_standard(100);
  for (const optics::Band& b : optics::bands()) {
    const ClearSkyColumn c = clear_sky_column(s, b, {1.0, 1.0, 1e6}, 45);
    double peak_p = 0, peak = -1;
    for (std::size_t k = 0; k + 1 < c.z_m.size(); ++k) {
      const double wf = (c.t_view[k + 1] - c.t_view[k]) / std::log(s.p_pa[k] / s.p_pa[k + 1]);
      if (wf > peak) peak = wf, peak_p = std::sqrt(s.p_pa[k] * s.p_pa[k + 1]);
    }
    const double bt = b.thermal ? optics::band_brightness_temperature(b, clear_sky_radiance(c, b, s.t_k[0])) : 0;
    std::printf("%-7s t_surface %.3f t2 %.3f tauR %.4f peak %.0f hPa BT %.2f\n", b.name.c_str(), c.t_view.front(),
                c.t_solar.front(), c.tau_rayleigh.front(), peak_p / 100, bt);
  }
}

}  // namespace
}  // namespace nephos::atmosphere
namespace nephos::atmosphere {
TEST(BandModel, DebugFit) {
  const optics::Band& b = optics::band(std::getenv("BAND") ? std::getenv("BAND") : "lwir");
  const int gi = std::getenv("GAS") ? std::atoi(std::getenv("GAS")) : 0;
  const BandGasModel& m = gas_model(b);
  for (const auto& s : m.sub) {
    const ExpSum& e = s.gas[gi];
    std::printf("sub %g-%g n=%d\n", s.nu_lo_cm1, s.nu_hi_cm1, e.n);
    for (int i = 0; i < e.n; ++i) std::printf("  k %g w %g\n", e.k[i], e.w[i]);
    for (double x = -8; x <= 4; x += 0.5) {
      const double w = std::pow(10.0, x);
      std::printf("  W %8.3g model %.4f fit %.4f\n", w,
                  band_model_transmittance(static_cast<Gas>(gi), s.nu_lo_cm1, s.nu_hi_cm1, w), e.transmittance(w));
    }
  }
}
}  // namespace nephos::atmosphere

namespace nephos::atmosphere {
TEST(ClearSky, SplitWindowDebug) {
  for (double scale : {0.25, 0.5, 1.0, 2.0, 3.0}) {
    const Profile s = fine_us_standard(100, scale, 10);
    const auto c13 = clear_sky_column(s, optics::band("lwir"), {1.0, 1.0, 1e6}, 45);
    const auto c15 = clear_sky_column(s, optics::band("lwir12"), {1.0, 1.0, 1e6}, 45);
    const double b13 = optics::band_brightness_temperature(optics::band("lwir"),
                                                           clear_sky_radiance(c13, optics::band("lwir"), s.t_k[0]));
    const double b15 = optics::band_brightness_temperature(optics::band("lwir12"),
                                                           clear_sky_radiance(c15, optics::band("lwir12"), s.t_k[0]));
    std::printf("PW %.2f cm Ts %.1f BT13 %.2f BT15 %.2f SW %.2f\n", s.precipitable_water_kg_m2() / 10, s.t_k[0], b13,
                b15, b13 - b15);
  }
}
}  // namespace nephos::atmosphere
