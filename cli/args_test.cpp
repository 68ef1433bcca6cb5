#include "cli/args.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace drape::cli {
namespace {

TEST(Args, ParsesFlagsOptionsAndPositionals) {
  Args a({"make", "shirt", "--size", "L", "--seed=3", "--json", "-o", "x.ply"}, {"--json"}, {"--size", "--seed", "-o"});
  EXPECT_EQ(a.positional(), (std::vector<std::string>{"make", "shirt"}));
  EXPECT_EQ(a.Get("--size", "M"), "L");
  EXPECT_EQ(*a.GetInt("--seed"), 3);
  EXPECT_TRUE(a.Flag("--json"));
  EXPECT_EQ(*a.Get("-o"), "x.ply");
  EXPECT_FALSE(a.help());
}

TEST(Args, RejectsUnknownOptionsAndBadNumbers) {
  EXPECT_THROW(Args({"--sise", "M"}, {}, {"--size"}), Error);
  EXPECT_THROW(Args({"--size"}, {}, {"--size"}), Error);
  Args a({"--seed", "x3"}, {}, {"--seed"});
  EXPECT_THROW(a.GetInt("--seed"), Error);
  try {
    Args({"--sise"}, {}, {"--size"});
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("--sise"), std::string::npos);
  }
}

// Release instances carry full 64-bit seeds; every one must be accepted back.
TEST(Args, SeedsTakeTheWhole64BitRange) {
  for (const char* s : {"0", "9223372036854775808", "18446744073709551615"}) {
    Args a({"--seed", s}, {}, {"--seed"});
    EXPECT_EQ(*a.GetSeed("--seed"), std::stoull(s)) << s;
  }
  for (const char* s : {"-1", "18446744073709551616", "1e3", "", "0x10"}) {
    Args a({"--seed=" + std::string(s)}, {}, {"--seed"});
    EXPECT_THROW(a.GetSeed("--seed"), Error) << s;
  }
  Args big({"-j", "99999999999999999999"}, {}, {"-j"});
  EXPECT_THROW(big.GetInt("-j"), Error);  // no silent clamp to LLONG_MAX
}

TEST(Args, ShortOptionGluedToItsValue) {
  Args a({"-j2", "-oout.ply"}, {}, {"-j", "-o"});
  EXPECT_EQ(*a.GetInt("-j"), 2);
  EXPECT_EQ(*a.Get("-o"), "out.ply");
  EXPECT_THROW(Args({"-x2"}, {}, {"-j"}), Error);
}

TEST(Args, NegativeNumbersArePositional) {
  Args a({"-0.5", "--x", "-2"}, {}, {"--x"});
  EXPECT_EQ(a.positional(), (std::vector<std::string>{"-0.5"}));
  EXPECT_EQ(*a.GetDouble("--x"), -2.0);
}

}  // namespace
}  // namespace drape::cli
