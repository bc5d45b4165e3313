// Shared by the BTF reader and store tests (test_btf_*.cpp, test_metrics_btf_store.cpp): a fresh
// path under the test scratch folder, the checks of a refused or warned-about read, and a BTF
// written as a store and opened again.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "btflod/core/result.hpp"
#include "btflod/offline/btf/btf_store.hpp"

namespace btflod_test {

// BTFLOD_TEST_TMP_DIR/name with whatever an earlier run left there removed.
inline std::filesystem::path fresh_tmp_path(const std::string& name) {
  const std::filesystem::path p = std::filesystem::path(BTFLOD_TEST_TMP_DIR) / name;
  std::filesystem::remove_all(p);
  return p;
}

// Expects r to be refused with a message that contains needle.
template <class T>
void expect_refused(const btflod::Result<T>& r, std::string_view needle) {
  ASSERT_FALSE(r);
  EXPECT_NE(r.message().find(needle), std::string::npos) << r.message();
}

// Expects r to be refused with status and a message that contains needle.
template <class T>
void expect_refused(const btflod::Result<T>& r, btflod::Status status, std::string_view needle) {
  ASSERT_FALSE(r);
  EXPECT_EQ(r.status(), status);
  EXPECT_NE(r.message().find(needle), std::string::npos) << r.message();
}

// Expects r to be read with exactly one warning, which contains needle.
template <class T>
void expect_one_warning(const btflod::Result<T>& r, std::string_view needle) {
  ASSERT_TRUE(r) << r.message();
  ASSERT_EQ(r->warnings.size(), 1u);
  EXPECT_NE(r->warnings[0].find(needle), std::string::npos);
}

// Writes btf as a store at path (values of value_type, block_texels texels a block) and opens
// it. Returns the open store, or the error of the write or of the open.
inline btflod::Result<btflod::BtfStore> write_and_open_store(const btflod::BtfFloat& btf, const std::string& path,
                                                             btflod::BtfStoreValueType value_type,
                                                             uint32_t block_texels) {
  if (const btflod::VoidResult written = btflod::write_btf_store(btf, path, value_type, block_texels); !written)
    return written.error();
  return btflod::BtfStore::open(path);
}

}  // namespace btflod_test
