// btflod-convert — the subcommand registry and a small option parser.
//
// Adding a command needs no edit to any existing file: create samples/convert/cmd_<name>.cpp
// (the CMakeLists.txt globs cmd_*.cpp; `// btflod-link:` lines at the top add libraries, see
// cmake/BtflodTargetDirectives.cmake) containing
//
//   #include "command.hpp"
//   namespace {
//   int run_frobnicate(int argc, char** argv) {      // argv[0] is "frobnicate"
//     btflod::convert::Options opt(argc, argv);
//     if (opt.wants_help()) { std::puts("usage: btflod-convert frobnicate FILE [--level N]"); return 0; }
//     auto level = opt.integer("level", 3, 0, 9);     // --level N or --level=N
//     ...
//     if (!opt.finish()) return 2;                    // unknown options / bad values → usage error
//     ...
//     return 0;                                       // 0 ok, 1 failure, 2 usage error
//   }
//   }  // namespace
//   BTFLOD_CONVERT_COMMAND(frobnicate, "one line of help", run_frobnicate);
//
// Commands are listed sorted by name by `btflod-convert --help`.
#pragma once

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace btflod::convert {

/// Exit codes shared by all commands.
inline constexpr int kExitOk = 0;
inline constexpr int kExitFailure = 1;
inline constexpr int kExitUsage = 2;

using CommandFunction = int (*)(int argc, char** argv);

struct Command {
  const char* name;
  const char* help;
  CommandFunction run;
};

/// All registered commands (function-local static: safe against static initialisation order).
inline std::vector<Command>& command_registry() {
  static std::vector<Command> commands;
  return commands;
}

/// Registers a command at static-initialisation time (use BTFLOD_CONVERT_COMMAND).
struct CommandRegistrar {
  CommandRegistrar(const char* name, const char* help, CommandFunction run) {
    command_registry().push_back({name, help, run});
  }
};

/// Finds a command by name; null when none has that name.
inline const Command* find_command(std::string_view name) {
  for (const auto& c : command_registry())
    if (name == c.name) return &c;
  return nullptr;
}

/// Commands sorted by name.
inline std::vector<Command> sorted_commands() {
  auto v = command_registry();
  std::sort(v.begin(), v.end(), [](const Command& a, const Command& b) { return std::string_view(a.name) < b.name; });
  return v;
}

#define BTFLOD_CONVERT_COMMAND(name, help, function) \
  static const ::btflod::convert::CommandRegistrar btflod_convert_command_##name { #name, help, function }

/// Parses `--name value`, `--name=value`, `-n value` and flags. Query every option the command
/// knows, then call finish(): anything left that starts with '-' is reported as unknown, and
/// the remaining words are the positional arguments. Errors are printed to stderr.
class Options {
 public:
  /// argv[0] is the command name and is skipped.
  Options(int argc, char** argv) {
    for (int i = 1; i < argc; ++i) tokens_.push_back({argv[i], false});
    command_ = argc > 0 ? argv[0] : "";
  }

  /// True for -h / --help (and consumes it).
  bool wants_help() { return flag("help", 'h'); }

  /// True when --name (or -s) is present; consumes it.
  bool flag(std::string_view name, char short_name = 0) {
    bool found = false;
    for (auto& t : tokens_) {
      if (t.used) continue;
      if (is_long(t.text, name) || is_short(t.text, short_name)) {
        t.used = true;
        found = true;
      }
    }
    return found;
  }

  /// The value of --name V / --name=V / -s V (the last one wins), or nullopt when absent.
  /// A missing value after the option is an error (reported by finish()).
  std::optional<std::string> value(std::string_view name, char short_name = 0) {
    std::optional<std::string> out;
    for (size_t i = 0; i < tokens_.size(); ++i) {
      auto& t = tokens_[i];
      if (t.used) continue;
      const std::string& s = t.text;
      if (s.size() > name.size() + 3 && s.compare(0, 2, "--") == 0 && s.compare(2, name.size(), name) == 0 &&
          s[2 + name.size()] == '=') {
        t.used = true;
        out = s.substr(3 + name.size());
      } else if (is_long(s, name) || is_short(s, short_name)) {
        t.used = true;
        if (i + 1 < tokens_.size() && !tokens_[i + 1].used) {
          tokens_[i + 1].used = true;
          out = tokens_[i + 1].text;
          ++i;
        } else {
          error("option " + s + " needs a value");
        }
      }
    }
    return out;
  }

  /// The value of --name or `fallback`.
  std::string string(std::string_view name, std::string fallback, char short_name = 0) {
    auto v = value(name, short_name);
    return v ? *v : std::move(fallback);
  }

  /// An integer option in [lo, hi]; `fallback` when absent. Bad values are errors.
  long long integer(std::string_view name, long long fallback, long long lo, long long hi, char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return fallback;
    errno = 0;
    char* end = nullptr;
    const long long x = std::strtoll(v->c_str(), &end, 10);
    if (errno != 0 || end == v->c_str() || *end != '\0' || x < lo || x > hi) {
      error("--" + std::string(name) + " " + *v + ": expected an integer in [" + std::to_string(lo) + ", " +
            std::to_string(hi) + "]");
      return fallback;
    }
    return x;
  }

  /// An unsigned 64-bit integer option (e.g. a seed); `fallback` when absent.
  unsigned long long unsigned_integer(std::string_view name, unsigned long long fallback, char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return fallback;
    errno = 0;
    char* end = nullptr;
    const unsigned long long x = std::strtoull(v->c_str(), &end, 0);
    if (errno != 0 || end == v->c_str() || *end != '\0' || (*v)[0] == '-') {
      error("--" + std::string(name) + " " + *v + ": expected a non-negative integer");
      return fallback;
    }
    return x;
  }

  /// A floating-point option in [lo, hi]; `fallback` when absent.
  double number(std::string_view name, double fallback, double lo, double hi, char short_name = 0) {
    auto v = value(name, short_name);
    if (!v) return fallback;
    char* end = nullptr;
    const double x = std::strtod(v->c_str(), &end);
    if (end == v->c_str() || *end != '\0' || !(x >= lo && x <= hi)) {
      error("--" + std::string(name) + " " + *v + ": expected a number in [" + std::to_string(lo) + ", " +
            std::to_string(hi) + "]");
      return fallback;
    }
    return x;
  }

  /// Records a usage error (printed by finish()).
  void error(std::string message) { errors_.push_back(std::move(message)); }

  /// Collects the positional arguments and reports unknown options and recorded errors on
  /// stderr. Returns false when there was any error (the command should exit with kExitUsage).
  bool finish() {
    positional_.clear();
    for (auto& t : tokens_) {
      if (t.used) continue;
      if (t.text.size() > 1 && t.text[0] == '-') {
        errors_.push_back("unknown option " + t.text);
      } else {
        positional_.push_back(t.text);
      }
      t.used = true;
    }
    for (const auto& e : errors_) std::fprintf(stderr, "btflod-convert %s: %s\n", command_.c_str(), e.c_str());
    return errors_.empty();
  }

  /// Positional arguments, in order (valid after finish()).
  const std::vector<std::string>& positional() const noexcept { return positional_; }

 private:
  struct Token {
    std::string text;
    bool used;
  };
  static bool is_long(const std::string& s, std::string_view name) {
    return s.size() == name.size() + 2 && s.compare(0, 2, "--") == 0 && s.compare(2, std::string::npos, name) == 0;
  }
  static bool is_short(const std::string& s, char c) { return c != 0 && s.size() == 2 && s[0] == '-' && s[1] == c; }

  std::string command_;
  std::vector<Token> tokens_;
  std::vector<std::string> positional_;
  std::vector<std::string> errors_;
};

}  // namespace btflod::convert
