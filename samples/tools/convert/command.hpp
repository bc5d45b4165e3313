// btflod-convert — the subcommand registry and its commands' option parser.
//
// Adding a command needs no edit to any existing file: create samples/tools/convert/cmd_<name>.cpp
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
#include <string>
#include <string_view>
#include <vector>

#include "common/arguments.hpp"

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

/// A command's options: the samples' parser (common/arguments.hpp), its messages prefixed with
/// "btflod-convert <command>".
class Options : public samples::Arguments {
 public:
  /// argv[0] is the command name and is skipped.
  Options(int argc, char** argv)
      : samples::Arguments(std::string("btflod-convert ") + (argc > 0 ? argv[0] : ""), argc, argv) {}
};

}  // namespace btflod::convert
