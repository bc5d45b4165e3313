// btflod samples — generated tables in the docs: the tools that measure something (replay,
// progressive, visibility) rewrite their own block of a Markdown file in place.
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>

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

/// The command written into a generated block: `program` (the tool's name, not the path it was
/// started from) followed by argv[1], ..., argv[argc - 1], separated by single spaces.
inline std::string command_line(std::string_view program, int argc, char** argv) {
  std::string command(program);
  for (int i = 1; i < argc; ++i) command += std::string(" ") + argv[i];
  return command;
}

/// A measuring tool's run as its report describes it: the command line (command_line()), the
/// output folder, created with its parents on construction (a failure is kept in folder_error()
/// for the tool to report or ignore), and the wall-clock seconds since the folder was created.
class MeasuredRun {
 public:
  MeasuredRun(std::string_view program, int argc, char** argv, const std::string& out_folder)
      : command_(command_line(program, argc, argv)), folder_error_(create_folder(out_folder)) {}

  const std::string& command() const noexcept { return command_; }
  const std::error_code& folder_error() const noexcept { return folder_error_; }
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }

 private:
  static std::error_code create_folder(const std::string& path) {
    std::error_code ec;
    std::filesystem::create_directories(path, ec);
    return ec;
  }

  std::string command_;
  std::error_code folder_error_;
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

}  // namespace btflod::samples
