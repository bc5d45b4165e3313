// btflod — whole-file and positional file I/O returning Result (never throws on I/O errors).
#pragma once

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "btflod/core/result.hpp"

namespace btflod {

/// Reads a whole file. Returns io_error with the path and errno text on failure, or
/// insufficient_space when the file is larger than max_bytes (a guard against hostile sizes).
inline Result<std::vector<uint8_t>> read_file_bytes(const std::string& path, uint64_t max_bytes = (uint64_t{1} << 34)) {
  std::FILE* f = std::fopen(path.c_str(), "rb");
  if (!f) return make_error(Status::io_error, "%s: cannot open: %s", path.c_str(), std::strerror(errno));
  std::vector<uint8_t> bytes;
  if (std::fseek(f, 0, SEEK_END) == 0) {
    const long size = std::ftell(f);
    if (size >= 0 && static_cast<uint64_t>(size) > max_bytes) {
      std::fclose(f);
      return make_error(Status::insufficient_space, "%s: file has %ld bytes, limit is %llu", path.c_str(), size,
                        static_cast<unsigned long long>(max_bytes));
    }
    if (size > 0) bytes.reserve(static_cast<size_t>(size));
    std::fseek(f, 0, SEEK_SET);
  }
  uint8_t buffer[1 << 16];
  size_t n = 0;
  while ((n = std::fread(buffer, 1, sizeof buffer, f)) > 0) {
    bytes.insert(bytes.end(), buffer, buffer + n);
    if (bytes.size() > max_bytes) {
      std::fclose(f);
      return make_error(Status::insufficient_space, "%s: more than %llu bytes", path.c_str(),
                        static_cast<unsigned long long>(max_bytes));
    }
  }
  const bool failed = std::ferror(f) != 0;
  std::fclose(f);
  if (failed) return make_error(Status::io_error, "%s: read error", path.c_str());
  return bytes;
}

/// Writes bytes to a file, replacing it. Writes to `path.tmp` first and renames, so a failed
/// write never leaves a half-written file under the final name.
inline VoidResult write_file_bytes(const std::string& path, std::span<const uint8_t> bytes) {
  const std::string tmp = path + ".tmp";
  std::FILE* f = std::fopen(tmp.c_str(), "wb");
  if (!f) return make_error(Status::io_error, "%s: cannot create: %s", tmp.c_str(), std::strerror(errno));
  const size_t written = bytes.empty() ? 0 : std::fwrite(bytes.data(), 1, bytes.size(), f);
  const bool close_failed = std::fclose(f) != 0;
  if (written != bytes.size() || close_failed) {
    std::remove(tmp.c_str());
    return make_error(Status::io_error, "%s: short write (%zu of %zu bytes)", path.c_str(), written, bytes.size());
  }
  if (std::rename(tmp.c_str(), path.c_str()) != 0) {
    std::remove(tmp.c_str());
    return make_error(Status::io_error, "%s: cannot rename from %s: %s", path.c_str(), tmp.c_str(),
                      std::strerror(errno));
  }
  return {};
}

}  // namespace btflod
