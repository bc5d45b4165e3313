// Shared by the tests that feed a decoder a decompression bomb (test_codec_tile.cpp,
// test_codec_tile_libdeflate.cpp, test_lod_feedback_trace.cpp): a small raw deflate stream
// that inflates to many zero bytes.
#pragma once

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace btflod_test {

// n zero bytes deflated at level 9 as one raw stream (no zlib header or trailer): a payload of
// about n / 1000 bytes that inflates to n. Returns an empty vector (after a failed expectation)
// when zlib fails.
inline std::vector<uint8_t> deflated_zeros(size_t n) {
  std::vector<uint8_t> zeros(n, 0);
  z_stream z{};
  if (deflateInit2(&z, 9, Z_DEFLATED, -15, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    ADD_FAILURE() << "deflateInit2 failed";
    return {};
  }
  std::vector<uint8_t> packed(deflateBound(&z, static_cast<uLong>(zeros.size())));
  z.next_in = zeros.data();
  z.avail_in = static_cast<uInt>(zeros.size());
  z.next_out = packed.data();
  z.avail_out = static_cast<uInt>(packed.size());
  const int status = deflate(&z, Z_FINISH);
  packed.resize(z.total_out);
  deflateEnd(&z);
  EXPECT_EQ(status, Z_STREAM_END);
  if (status != Z_STREAM_END) return {};
  return packed;
}

}  // namespace btflod_test
