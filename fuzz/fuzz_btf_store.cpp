// libFuzzer target: the BTF store reader (offline/btf/btf_store.hpp) on hostile bytes, as given and
// with its two CRCs recomputed (to get past them). The header parser runs on the input as a
// whole file; an input it accepts is also opened as a file (memfd) and read column block by
// column block, so the checksum table, the block offsets and the half/float conversion are
// exercised on every accepted layout (ASan checks every access).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

#include "btflod/offline/btf/btf_store.hpp"

namespace {

void parse_and_read(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  auto info = btflod::parse_btf_store_header(bytes, size);
  if (!info) return;
  // parse_btf_store_header checked the file size, so rows · columns is bounded by the input.
  const int fd = ::memfd_create("fuzz_btf_store", 0);
  if (fd < 0) return;
  size_t off = 0;
  while (off < size) {
    const ssize_t put = ::write(fd, data + off, size - off);
    if (put <= 0) break;
    off += static_cast<size_t>(put);
  }
  auto store = btflod::BtfStore::open("/proc/self/fd/" + std::to_string(fd));
  if (store) {
    const size_t m = store->rows(), n = store->columns();
    std::vector<float> out(m * store->info().block_texels);
    std::vector<uint8_t> scratch;
    for (size_t t0 = 0; t0 < n; t0 += store->info().block_texels) {
      const size_t cnt = std::min<size_t>(store->info().block_texels, n - t0);
      if (!store->read_columns(t0, cnt, out.data(), m, scratch)) break;
    }
    // The evaluation's reader: every view's chunks, lights [0, min(n_light, 2)) (bounded output).
    const size_t nl = std::min<size_t>(store->info().lights.size(), 2);
    if (n * nl * 3 <= (size_t{1} << 22)) {
      std::vector<float> images(n * nl * 3);
      for (size_t v = 0; v < store->info().views.size(); ++v)
        if (!store->read_view_images(v, 0, nl, images, scratch)) break;
    }
  }
  ::close(fd);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  parse_and_read(data, size);
  // The same bytes with the header CRC and the checksum table's CRC recomputed, so that
  // mutations of the fields reach the validation and reading code behind the checksums.
  uint32_t header_bytes = 0;
  if (size < 16) return 0;
  std::memcpy(&header_bytes, data + 12, 4);
  if (header_bytes < 8 || header_bytes > size) return 0;
  std::vector<uint8_t> fixed(data, data + size);
  const uint32_t crc = btflod::crc32_of(std::span<const uint8_t>(fixed.data(), header_bytes - 4));
  std::memcpy(fixed.data() + header_bytes - 4, &crc, 4);
  auto info = btflod::parse_btf_store_header(fixed, fixed.size());
  if (info && info->checksum_bytes() <= fixed.size()) {
    const size_t table = static_cast<size_t>(info->checksum_bytes());
    const uint32_t tcrc = btflod::crc32_of(std::span<const uint8_t>(fixed.data() + size - table, table - 4));
    std::memcpy(fixed.data() + size - 4, &tcrc, 4);
  }
  parse_and_read(fixed.data(), fixed.size());
  return 0;
}
