// libFuzzer target: the BTF store reader (btf/btf_store.hpp) on hostile bytes. The header parser
// runs on the input as a whole file; an input it accepts is also opened as a file (memfd) and
// read column block by column block, so the checksum table, the block offsets and the half/float
// conversion are exercised on every accepted layout (ASan checks every access).
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <sys/mman.h>
#include <unistd.h>

#include "btflod/btf/btf_store.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  auto info = btflod::parse_btf_store_header(bytes, size);
  if (!info) return 0;
  // parse_btf_store_header checked the file size, so rows · columns is bounded by the input.
  const int fd = ::memfd_create("fuzz_btf_store", 0);
  if (fd < 0) return 0;
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
  }
  ::close(fd);
  return 0;
}
