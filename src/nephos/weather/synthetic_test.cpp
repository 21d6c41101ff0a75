#include "nephos/weather/synthetic.hpp"

#include <gtest/gtest.h>

#include <cstring>

#include "nephos/core/error.hpp"
#include "nephos/core/parallel.hpp"

namespace nephos::weather {

TEST(SyntheticWeather, DeterministicFromSeedWhateverTheThreads) {
  SyntheticWeatherParams p;
  p.seed = 99;
  set_threads(1);
  const WeatherGrid a = make_synthetic_weather(p);
  set_threads(2);
  const WeatherGrid b = make_synthetic_weather(p);
  p.seed = 100;
  const WeatherGrid c = make_synthetic_weather(p);
  set_threads(0);
  const std::size_t n = a.grid().size();
  for (int k = 0; k < a.level_count(); ++k) {
    EXPECT_EQ(std::memcmp(a.level_data(Field::relative_humidity, k), b.level_data(Field::relative_humidity, k),
                          n * sizeof(float)),
              0);
  }
  EXPECT_NE(std::memcmp(a.level_data(Field::relative_humidity, 5), c.level_data(Field::relative_humidity, 5),
                        n * sizeof(float)),
            0);
}

TEST(SyntheticWeather, HeightsIncreaseUpwardAndFieldsAreComplete) {
  const WeatherGrid w = make_synthetic_weather({});
  EXPECT_TRUE(missing_for_masks(w).empty());
  EXPECT_TRUE(missing_for_winds(w).empty());
  for (int k = 1; k < w.level_count(); ++k)
    EXPECT_GT(w.value(Field::geopotential_height, k, 36, 0), w.value(Field::geopotential_height, k - 1, 36, 0));
}

TEST(SyntheticWeather, RejectsResolutionThatDoesNotDivide180) {
  SyntheticWeatherParams p;
  p.resolution_deg = 7;
  EXPECT_THROW(make_synthetic_weather(p), ValueError);
}

}  // namespace nephos::weather
