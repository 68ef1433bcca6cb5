// Helpers shared by the GoogleTest suites. Header-only; include it from *_test.cpp only
// (it includes GoogleTest, which the libraries do not link).
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>

#include "common/error.h"

namespace drape {

// The message of the drape::Error f throws ("" if it throws none).
inline std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// GoogleTest's temporary folder / name, emptied and created.
inline std::filesystem::path FreshTempDir(const std::string& name) {
  const std::filesystem::path d = std::filesystem::path(::testing::TempDir()) / name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

}  // namespace drape

// EXPECT that `text` contains `part`, printing `text` when it does not.
#define EXPECT_CONTAINS(text, part) EXPECT_NE(std::string(text).find(part), std::string::npos) << (text)
