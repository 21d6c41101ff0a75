#include "nephos/clouds/displacement.hpp"

#include <cmath>

#include "nephos/weather/sampler.hpp"

namespace nephos::clouds {

earth::Vec3 WindField::at(const earth::Vec3& p) const {
  const earth::Vec3 v(velocity_m_s.sample(p));
  return v - glm::dot(v, p) * p;  // keep it tangent (interpolation leaves a tiny radial part)
}

WindField make_wind_field(const weather::WeatherGrid& weather, double altitude_m, int n) {
  WindField w;
  w.altitude_m = altitude_m;
  w.velocity_m_s = CubeMap<glm::vec3>(n);
  const weather::WeatherSampler sampler(weather);
  w.velocity_m_s.fill([&](const earth::Vec3& d) {
    const earth::Geodetic g = earth::geodetic(d * earth::radius_m);
    const weather::WeatherSample s = sampler.sample(g.lat_deg, g.lon_deg, altitude_m);
    const double u = std::isnan(s.u_m_s) ? 0.0 : s.u_m_s, v = std::isnan(s.v_m_s) ? 0.0 : s.v_m_s;
    return glm::vec3(u * earth::local_east(d) + v * earth::local_north(d));
  });
  return w;
}

earth::Vec3 trace_upwind(const WindField& wind, earth::Vec3 p, double seconds, double step_s) {
  const double r = earth::radius_m + wind.altitude_m;
  const int steps = std::max(1, static_cast<int>(std::ceil(seconds / step_s)));
  const double h = -seconds / steps / r;  // backwards in time, per unit radius
  auto f = [&](const earth::Vec3& q) { return wind.at(q); };
  for (int s = 0; s < steps; ++s) {
    const earth::Vec3 k1 = f(p);
    const earth::Vec3 k2 = f(glm::normalize(p + 0.5 * h * k1));
    const earth::Vec3 k3 = f(glm::normalize(p + 0.5 * h * k2));
    const earth::Vec3 k4 = f(glm::normalize(p + h * k3));
    p = glm::normalize(p + h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4));
  }
  return p;
}

DisplacementMap DisplacementMap::build(const WindField& wind, double hours, int n, double step_s) {
  DisplacementMap m;
  m.hours_ = hours;
  if (hours == 0) return m;
  m.upwind_ = CubeMap<glm::vec3>(n);
  m.upwind_.fill([&](const earth::Vec3& d) { return glm::vec3(trace_upwind(wind, d, hours * 3600.0, step_s)); });
  return m;
}

DisplacementMap DisplacementMap::advanced(const WindField& wind, double hours, double step_s, int n) const {
  if (is_identity()) return build(wind, hours_ + hours, n, step_s);
  DisplacementMap m;
  m.hours_ = hours_ + hours;
  m.upwind_ = CubeMap<glm::vec3>(upwind_.size());
  m.upwind_.fill(
      [&](const earth::Vec3& d) { return glm::vec3(upwind(trace_upwind(wind, d, hours * 3600.0, step_s))); });
  return m;
}

}  // namespace nephos::clouds
