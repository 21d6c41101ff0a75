#include "nephos/io/ply.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "nephos/core/error.hpp"
#include "nephos/core/test_support.hpp"

using namespace nephos;

TEST(Ply, RoundTripAndHeader) {
  const auto path = test_support::temp_path("points.ply");
  io::PlyPoints p;
  p.x = {1.5f, -2}, p.y = {0, 3}, p.z = {1000, 2500.25f};
  p.rgba = {10, 20, 30, 255, 200, 201, 202, 7};
  p.radius = {50, 60};
  p.comments = {"nephos particles", "origin 45N 10E"};
  io::write_ply(path, p);
  std::ifstream in(path, std::ios::binary);
  std::string first, second;
  std::getline(in, first);
  std::getline(in, second);
  EXPECT_EQ(first, "ply");
  EXPECT_EQ(second, "format binary_little_endian 1.0");
  // Header plus 2 records of 20 bytes.
  const auto size = std::filesystem::file_size(path);
  const io::PlyPoints q = io::read_ply(path);
  EXPECT_EQ(q.x, p.x);
  EXPECT_EQ(q.z, p.z);
  EXPECT_EQ(q.rgba, p.rgba);
  EXPECT_EQ(q.radius, p.radius);
  EXPECT_EQ(q.comments, p.comments);
  EXPECT_GT(size, 40u);
  p.radius.pop_back();
  EXPECT_THROW(io::write_ply(path, p), ValueError);  // lengths disagree; the old file stays
  EXPECT_EQ(std::filesystem::file_size(path), size);
}
