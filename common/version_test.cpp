#include "common/version.h"

#include <gtest/gtest.h>

#include <string>

namespace drape {
namespace {

TEST(RunProvenance, NamesTheCodeTheCpuAndItsCores) {
  const Json p = RunProvenance();
  EXPECT_EQ(p.at("code_version").get<std::string>(), GitVersion());
  EXPECT_FALSE(p.at("code_version").get<std::string>().empty());
  EXPECT_FALSE(p.at("cpu").get<std::string>().empty());
  EXPECT_GE(p.at("cores").get<int>(), 1);
}

}  // namespace
}  // namespace drape
