// Shared by the tests that write a fuzzer's seeds (test_codec_container.cpp, test_codec_tile.cpp,
// test_codec_tile_zstd.cpp): the folder the seeds go to, and writing and reading one seed.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <span>
#include <string>
#include <vector>

namespace btflod_test {

// The folder a test writes a fuzzer's seeds into: the one the environment variable env_var
// names when it is set and not empty (naming fuzz/corpus/<fuzzer> refreshes that corpus), else
// BTFLOD_TEST_TMP_DIR/fallback. The constructor creates it when missing.
class FuzzSeedFolder {
 public:
  FuzzSeedFolder(const char* env_var, const std::string& fallback) {
    const char* env = std::getenv(env_var);
    dir_ = env != nullptr && env[0] != '\0' ? std::filesystem::path(env)
                                            : std::filesystem::path(BTFLOD_TEST_TMP_DIR) / fallback;
    std::filesystem::create_directories(dir_);
  }

  // Writes bytes as the seed file `name`; a failed write fails the calling test.
  void write(const std::string& name, std::span<const uint8_t> bytes) const {
    std::ofstream f(dir_ / name, std::ios::binary);
    f.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
    EXPECT_TRUE(f.good()) << name;
  }

  // The bytes of the seed file `name` (empty when it cannot be read).
  std::vector<uint8_t> read(const std::string& name) const {
    std::ifstream f(dir_ / name, std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(f), {});
  }

 private:
  std::filesystem::path dir_;
};

}  // namespace btflod_test
