#include "test_data.h"

#include <gtest/gtest.h>

#include <filesystem>

namespace hapvox::testing {

std::string source_path(const std::string& relative) {
  return (std::filesystem::path(HAPVOX_SOURCE_DIR) / relative).string();
}

std::string hapvox_binary() { return HAPVOX_BINARY; }

std::string scratch_dir() {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string name = "hapvox_test";
  if (info != nullptr) {
    name += std::string("_") + info->test_suite_name() + "_" + info->name();
  }
  for (char& c : name) {
    if (c == '/') c = '_';
  }
  const auto dir = std::filesystem::temp_directory_path() / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

}  // namespace hapvox::testing
