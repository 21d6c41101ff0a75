#include "nephos/core/config.hpp"

#include <gtest/gtest.h>

#include <limits>

#include "nephos/core/error.hpp"

namespace nephos {

TEST(ParamDict, ReadsValuesAndDefaults) {
  auto d = ParamDict::from_string("a = 1.5\nb = 2\nname = 'x'\nflag = true\nlist = [1, 2.5]\n[t]\nc = 3\n");
  EXPECT_EQ(d.get("a", 0.0), 1.5);
  EXPECT_EQ(d.get("b", 0.0), 2.0);  // an integer where a number is expected is fine
  EXPECT_EQ(d.get("b", 0), 2);
  EXPECT_EQ(d.get("name", "y"), "x");
  EXPECT_TRUE(d.get("flag", false));
  EXPECT_EQ(d.get("list", std::vector<double>{}), (std::vector<double>{1, 2.5}));
  EXPECT_EQ(d.table("t").get("c", 0), 3);
  EXPECT_EQ(d.get("missing", 9.0), 9.0);
  EXPECT_NO_THROW(d.check_unused());
}

TEST(ParamDict, UnknownKeyIsReportedWithItsLine) {
  auto d = ParamDict::from_string("a = 1\n[t]\nc = 3\ntypo_key = 4\n", "cfg.toml");
  d.get("a", 0);
  d.table("t").get("c", 0);
  try {
    d.check_unused();
    FAIL() << "expected ConfigError";
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.context().key, "t.typo_key");
    EXPECT_EQ(e.context().line, 4);
    EXPECT_EQ(e.context().file, "cfg.toml");
    EXPECT_NE(std::string(e.what()).find("cfg.toml:4"), std::string::npos);
  }
}

TEST(ParamDict, UnreadTableIsReported) {
  auto d = ParamDict::from_string("[unknown_table]\nx = 1\n");
  EXPECT_THROW(d.check_unused(), ConfigError);
}

// A value of the wrong type: the error names the key, what was expected and what was found.
TEST(ParamDict, WrongTypeNamesKeyExpectationAndValue) {
  auto d = ParamDict::from_string("a = 'text'\nb = 2.5\nc = nan\nd = [1, 2]\ne = [1, 'x']\n", "c.toml");
  auto message = [&](auto get) -> std::string {
    try {
      get();
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  const std::string a = message([&] { d.get("a", 0.0); });
  EXPECT_NE(a.find("key 'a'"), std::string::npos) << a;
  EXPECT_NE(a.find("expected a number (not nan), got the string \"text\""), std::string::npos) << a;
  EXPECT_NE(message([&] { d.get("b", 1); }).find("expected an integer, got 2.5"), std::string::npos);
  EXPECT_NE(message([&] { d.get("c", 0.0); }).find("got nan"), std::string::npos);
  EXPECT_NE(message([&] { d.get("d", false); }).find("expected true or false, got an array"), std::string::npos);
  EXPECT_NE(message([&] { d.get("e", std::vector<double>{}); }).find("got the string \"x\" in it"), std::string::npos);
}

TEST(ParamDict, NanIsNotANumberButInfinityIsNoBound) {
  // TOML spells them nan and inf: no nephos parameter means nan, while -inf may stand for "no
  // lower bound" (configs/masks.toml); get_in() with finite bounds rejects it.
  auto d = ParamDict::from_string("a = nan\nb = -inf\nc = [1.0, nan]\n", "c.toml");
  EXPECT_THROW(d.get("a", 0.0), ConfigError);
  EXPECT_EQ(d.get("b", 0.0), -std::numeric_limits<double>::infinity());
  EXPECT_THROW(d.get_in("b", 0.0, -1e9, 1e9), ConfigError);
  EXPECT_THROW(d.get("c", std::vector<double>{}), ConfigError);
}

TEST(ParamDict, RangedValuesNameKeyLineAndRange) {
  auto d = ParamDict::from_string("[t]\nx = 2.5\ny = 300\nz = 5000000000\n", "r.toml");
  const ParamDict t = d.table("t");
  EXPECT_EQ(t.get_in("x", 0.0, 0.0, 10.0), 2.5);
  EXPECT_EQ(t.get_in("absent", 7, 0, 10), 7);  // an absent key gives the default
  try {
    t.get_in("y", 0, 0, 255);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.context().key, "t.y");
    EXPECT_EQ(e.context().line, 3);
    EXPECT_NE(std::string(e.what()).find("must be in [0, 255], got 300"), std::string::npos) << e.what();
  }
  EXPECT_THROW(t.get_in("x", 0.0, 3.0, 10.0), ConfigError);
  EXPECT_THROW(t.get("z", 0), ConfigError);  // beyond a 32-bit int: not silently wrapped
}

TEST(ParamDict, SyntaxErrorHasLine) {
  try {
    ParamDict::from_string("a = 1\nb = = 2\n", "bad.toml");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_EQ(e.context().line, 2);
  }
}

TEST(ParamDict, MissingFileIsIoError) { EXPECT_THROW(ParamDict::from_file("/nonexistent/x.toml"), IoError); }

}  // namespace nephos
