// btflod samples — generated tables in the docs: the tools that measure something (replay,
// progressive, visibility) rewrite their own block of a Markdown file in place.
#pragma once

#include <fstream>
#include <sstream>
#include <string>

namespace btflod::samples {

/// Replaces the block between "<!-- NAME:begin -->" and "<!-- NAME:end -->" in the file at
/// `path` with `body` (markers kept), or appends the block when the file or the markers are
/// missing. Returns false when the file cannot be written.
inline bool replace_doc_block(const std::string& path, const std::string& name, const std::string& body) {
  std::string text;
  {
    std::ifstream in(path, std::ios::binary);
    if (in) {
      std::ostringstream ss;
      ss << in.rdbuf();
      text = ss.str();
    }
  }
  const std::string begin = "<!-- " + name + ":begin -->", end = "<!-- " + name + ":end -->";
  const std::string block = begin + "\n" + body + end;
  const size_t b = text.find(begin), e = text.find(end);
  if (b != std::string::npos && e != std::string::npos && e > b)
    text.replace(b, e + end.size() - b, block);
  else
    text += "\n" + block + "\n";
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
  return static_cast<bool>(out);
}

}  // namespace btflod::samples
